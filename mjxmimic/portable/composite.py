"""Composite policies (DeepMimic's section 7): independently trained experts, one clip each, in one
file; at play time a gate picks, at every control step, the expert that acts next. No JAX.

The gate: each expert's value network grades the present state against that expert's own clip
(the playing expert at its own clip time, a looping expert at the playing clip's phase, a
non-looping one at its clip's start, which is where it would begin), and the next expert is drawn
from softmax(V / temperature). A non-looping expert that has just played its clip to the end is
left out until another expert has been drawn (no immediate repeat). The drawn expert follows its
clip from that time on, from the present state; falls do not end an episode.

Recovery (`recovery_test`): while a looping expert walks, a push on the pelvis for 0.2 s in a
random direction knocks the character down (the root below half the locomotion clip's mean root
height within 2 s; pushes that do not are counted apart). It has recovered when, within 5 s of
going down, a looping expert plays for 0.5 s with the root above 0.8 of that height and a mean
pose error below 0.5 rad.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np

from mjxmimic.core.errors import UserError
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.portable import policy_file
from mjxmimic.portable.policy_numpy import NumpyValue
from mjxmimic.task import push_protocol

FORMAT = "mjxmimic-composite"
FORMAT_VERSION = 1
TEMPERATURE = 0.3
# config sections whose every key must agree between experts (the simulation and what is observed)
SHARED_SECTIONS = ("env", "physics")

DOWN_FRACTION = 0.5  # root height / the locomotion clip's mean: down below this
UP_FRACTION = 0.8  # ... up above this
DETECT_DOWN_S = 2.0
RECOVER_WITHIN_S = 5.0
TRACK_S = 0.5
TRACK_POSE_RAD = 0.5
WALK_BEFORE_PUSH_S = 1.0
PUSH_S = 0.2


@dataclasses.dataclass
class Composite:
    experts: list[policy_file.PolicyFile]
    temperature: float = TEMPERATURE

    @property
    def names(self) -> list[str]:
        return [pf.clip().name for pf in self.experts]


def compose(experts: list[policy_file.PolicyFile], temperature: float = TEMPERATURE) -> Composite:
    """Check that the experts can share one simulation and one observation, then bundle them."""
    if len(experts) < 2:
        raise UserError("compose needs at least two experts")
    if not temperature > 0:
        raise UserError(f"--temperature {temperature}: must be positive")
    first = experts[0]
    for pf in experts:
        where = pf.path or "an expert"
        if "value" not in pf.params:
            raise UserError(f"{where}: holds no value network (exported before composites existed); "
                            f"export it again from its run folder")
        if "dataset" in pf.manifest:
            raise UserError(f"{where}: trained on a dataset of clips; a composite's experts have one clip each")
        if pf.manifest["character"]["sha256"] != first.manifest["character"]["sha256"]:
            raise UserError(f"{where}: another character than {first.path}'s")
        for section in SHARED_SECTIONS:
            mine, theirs = pf.manifest["config"][section], first.manifest["config"][section]
            for key in sorted(set(mine) | set(theirs)):
                if mine.get(key) != theirs.get(key):
                    raise UserError(f"{where}: config key '{section}.{key}' is {mine.get(key)!r}, "
                                    f"{first.path}'s is {theirs.get(key)!r}; experts must agree on it")
    return Composite(list(experts), float(temperature))


def write(composite: Composite, path: Path) -> Path:
    """One npz: each expert's policy file arrays under expertI/, a manifest naming them."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, np.ndarray] = {}
    for i, pf in enumerate(composite.experts):
        arrays.update({f"expert{i}/{k}": v for k, v in pf.arrays().items()})
        arrays[f"expert{i}/manifest"] = np.array(json.dumps(pf.manifest))
        arrays[f"expert{i}/character_xml"] = np.array(pf.character_xml)
    manifest = {"format": FORMAT, "format_version": FORMAT_VERSION, "temperature": composite.temperature,
                "experts": composite.names}
    arrays["manifest"] = np.array(json.dumps(manifest, indent=1))
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        np.savez_compressed(f, **arrays)
    tmp.replace(path)
    return path


def is_composite(path: Path) -> bool:
    """Whether `path` is a composite file (an npz whose manifest says so)."""
    path = Path(path)
    if path.suffix != ".npz" or not path.is_file():
        return False
    try:
        with np.load(path, allow_pickle=False) as z:
            return "manifest" in z.files and json.loads(str(z["manifest"])).get("format") == FORMAT
    except (OSError, ValueError, EOFError):
        return False


def read(path: Path) -> Composite:
    path = Path(path)
    data = policy_file.load_npz(path)
    manifest = json.loads(str(data["manifest"]))
    if manifest.get("format_version", 0) > FORMAT_VERSION:
        raise UserError(f"{path}: composite format version {manifest['format_version']} is newer than this "
                        f"mjxmimic reads ({FORMAT_VERSION}); update mjxmimic")
    experts = []
    for i in range(len(manifest["experts"])):
        prefix = f"expert{i}/"
        if prefix + "manifest" not in data:
            raise UserError(f"{path}: the manifest lists {len(manifest['experts'])} experts, expert {i} is missing")
        pf = policy_file.from_arrays({k[len(prefix):]: v for k, v in data.items() if k.startswith(prefix)},
                                     path / f"expert{i}")
        experts.append(pf)
    return Composite(experts, float(manifest["temperature"]))


class Gate:
    """The composite on MuJoCo C: one character, every expert's clip, the gate at every step."""

    def __init__(self, composite: Composite, seed: int = 0):
        first = composite.experts[0]
        self.composite = composite
        self.clips = [pf.clip() for pf in composite.experts]
        self.env = CpuEnv(first.config(), first.character(), self.clips)
        self.policies = [pf.policy() for pf in composite.experts]
        self.values = [NumpyValue(pf.params) for pf in composite.experts]
        self.rng = np.random.default_rng(seed)
        self.active = 0
        self.finished: int | None = None  # a non-looping expert that has just played to its end

    def reset(self, expert: int, t0: float) -> None:
        self.env.reset_at(t0, clip=expert)
        self.active, self.finished = expert, None

    def candidate_times(self) -> list[float]:
        return [float(self.env.time) if i == self.active else self.env.same_phase_time(i) if clip.loop else 0.0
                for i, clip in enumerate(self.clips)]

    def choose(self) -> tuple[int, np.ndarray, np.ndarray]:
        """Draw the next expert; returns it, its observation and every expert's value."""
        times = self.candidate_times()
        obs = [self.env.observe_as(i, t) for i, t in enumerate(times)]
        values = np.array([float(v(o)) for v, o in zip(self.values, obs, strict=True)])
        allowed = np.array([i != self.finished for i in range(len(values))])
        chosen = int(self.rng.choice(len(values), p=gate_probabilities(values, allowed, self.composite.temperature)))
        if chosen != self.active:
            self.env.play(chosen, times[chosen])
            self.active = chosen
        if self.finished is not None and chosen != self.finished:
            self.finished = None
        return chosen, obs[chosen], values

    def step(self, external_force: Any = None):
        """One control step: the gate draws, the drawn expert acts. Returns (CpuEnv.Step, expert)."""
        expert, obs, _ = self.choose()
        s = self.env.step(self.policies[expert](obs), external_force=external_force)
        if s.clip_end and not self.clips[expert].loop:
            self.finished = expert
        return s, expert


def gate_probabilities(values: np.ndarray, allowed: np.ndarray, temperature: float) -> np.ndarray:
    """softmax(V / temperature) over the allowed experts (0 for the others)."""
    logits = np.where(allowed, np.asarray(values, np.float64) / temperature, -np.inf)
    p = np.exp(logits - logits[allowed].max())
    return p / p.sum()


def recovery_test(composite: Composite, knockdowns: int = 50, force_n: float = 1000.0, seed: int = 0,
                  max_trials: int | None = None) -> dict[str, Any]:
    """Push the walking character over until `knockdowns` knock-downs (at most `max_trials`
    pushes, default 3x) and count the recoveries (module docstring). Seeded."""
    gate = Gate(composite, seed)
    env = gate.env
    loco = [i for i, c in enumerate(gate.clips) if c.loop]
    if not loco:
        raise UserError("the recovery test needs a looping (locomotion) expert in the composite")
    lead = loco[0]
    height = float(np.mean(gate.clips[lead].qpos[:, 2]))
    hz = round(1.0 / env.control_dt)
    rng = np.random.default_rng(seed)
    rows: list[dict[str, Any]] = []
    steps_by_expert = np.zeros(len(gate.clips), int)
    for trials in range(1, (max_trials or 3 * knockdowns) + 1):
        gate.reset(lead, float(rng.uniform(0.0, float(env.clip_durations[lead]))))
        turn = float(rng.uniform(0.0, 2 * np.pi))
        down_at, up_run, pose, recovered_at = None, 0, [], None
        total = round((WALK_BEFORE_PUSH_S + DETECT_DOWN_S + RECOVER_WITHIN_S) * hz)
        for k in range(total):
            pushing = round(WALK_BEFORE_PUSH_S * hz) <= k < round((WALK_BEFORE_PUSH_S + PUSH_S) * hz)
            force = push_protocol.wrench(env.data.qpos, force_n, turn, float(pushing), env.model.nbody, np) \
                if pushing else None
            s, expert = gate.step(force)
            steps_by_expert[expert] += 1
            z = float(env.data.qpos[2])
            if down_at is None:
                if k > round((WALK_BEFORE_PUSH_S + DETECT_DOWN_S) * hz):
                    break  # the push did not knock it down
                if k >= round(WALK_BEFORE_PUSH_S * hz) and z < DOWN_FRACTION * height:
                    down_at = k
                continue
            if k - down_at > RECOVER_WITHIN_S * hz:
                break
            if expert in loco and z > UP_FRACTION * height:
                up_run += 1
                pose.append(s.metrics["error/pose"])
            else:
                up_run, pose = 0, []
            if up_run >= round(TRACK_S * hz) and float(np.mean(pose[-up_run:])) < TRACK_POSE_RAD:
                recovered_at = k
                break
        if down_at is not None:
            rows.append({"down_s": round(down_at / hz, 3),
                         "recovered_after_s": None if recovered_at is None else round((recovered_at - down_at) / hz, 3)})
        if len(rows) >= knockdowns:
            break
    recovered = [r for r in rows if r["recovered_after_s"] is not None]
    share = steps_by_expert / max(steps_by_expert.sum(), 1)
    return {"knockdowns": len(rows), "pushes": trials, "force_n": force_n,
            "recovery_rate": len(recovered) / len(rows) if rows else float("nan"),
            "median_recovery_s": float(np.median([r["recovered_after_s"] for r in recovered])) if recovered else None,
            "expert_time_share": dict(zip(composite.names, [round(float(x), 4) for x in share], strict=True)),
            "temperature": composite.temperature, "seed": seed, "trials": rows}
