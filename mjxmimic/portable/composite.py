"""Composite policies (DeepMimic section 7; issue 14, parts 4 and 5): independently trained
experts in one file, a gate that picks the next expert every control step by a softmax of their
value estimates (mjxmimic.envs.composite), played on MuJoCo's CPU simulator. No JAX.

File (npz, format "mjxmimic-composite" version 1):

    manifest                     0-d str: JSON: format, format_version, mjxmimic_version, created,
                                 temperature, character (file, sha256), experts: per expert its
                                 name, clip, loop, duration_s, source (the file or run composed)
                                 and its own policy manifest (mjxmimic.portable.policy_file)
    character_xml                0-d str: the shared character's MJCF
    expert/<e>/<key>             expert e's policy-file arrays under their own keys: normalizer/*,
                                 policy/hidden_<i>/*, value/hidden_<i>/*, clip/qpos, clip/durations

Every expert observes its own clip's phase, so each expert's observation is built against its own
clip (envs.composite.expert_observations); they must share the character, the observation layout
and the control settings, which `compose` checks.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from mjxmimic import __version__
from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.envs import composite as gate_lib
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.portable import policy_file
from mjxmimic.portable.policy_file import PolicyFile
from mjxmimic.task import push_protocol
from mjxmimic.task import recovery as protocol

FORMAT = "mjxmimic-composite"
FORMAT_VERSION = 1
DEFAULT_TEMPERATURE = 0.3
COMPOSITE_TERMINATIONS = ("bad_state",)  # falls end nothing: getting up is the point
KNOCKED_STATE_EVERY = 3  # control steps between the knocked-down states that recovery_rate keeps


@dataclasses.dataclass
class Composite:
    manifest: dict[str, Any]
    experts: list[PolicyFile]
    path: Path | None = None

    @property
    def names(self) -> list[str]:
        return [e["name"] for e in self.manifest["experts"]]

    @property
    def temperature(self) -> float:
        return float(self.manifest["temperature"])

    @property
    def loops(self) -> list[bool]:
        return [bool(e["loop"]) for e in self.manifest["experts"]]

    def character(self):
        return self.experts[0].character()

    def config(self) -> config_lib.Config:
        """The first expert's config in evaluation conditions (the control settings are shared)."""
        return config_lib.evaluation_config(self.experts[0].config())

    def clips(self) -> list:
        """Every expert's clip, clip id = expert index."""
        return [pf.clip() for pf in self.experts]

    def start_expert(self, name: str | None = None) -> int:
        """The named expert, or the first looping one (the locomotion a trial starts in)."""
        if name is not None:
            if name not in self.names:
                raise UserError(f"unknown expert {name!r} (the composite's experts: {', '.join(self.names)})")
            return self.names.index(name)
        return self.loops.index(True)


# ------------------------------------------------------------------------------------- compose


def _observation_parts(pf: PolicyFile) -> list[tuple[str, int]]:
    return [(p["name"], p["size"]) for p in pf.manifest["observation"]["layout"]]


def check_experts(experts: list[PolicyFile]) -> None:
    """One line saying why these files cannot be composed, or nothing."""
    if len(experts) < 2:
        raise UserError(f"compose needs at least two experts, got {len(experts)}"
                        + (f" ({experts[0].path})" if experts else ""))
    first = experts[0]
    for pf in experts:
        if not pf.has_value():
            raise UserError(f"{pf.path}: the policy file lacks its value network (exported before it was "
                            f"carried); re-export it with `mjxmimic export RUN`")
        if "dataset" in pf.manifest:
            raise UserError(f"{pf.path}: a policy of several clips; compose takes single-clip experts")
        if pf.manifest["config"]["task"]["name"]:
            raise UserError(f"{pf.path}: a policy with the {pf.manifest['config']['task']['name']!r} task; "
                            f"compose takes imitation experts")
        a, b = first.manifest["character"], pf.manifest["character"]
        if a["sha256"] != b["sha256"]:
            raise UserError(f"{first.path} and {pf.path} are for different characters "
                            f"({a['file']} {a['sha256'][:12]}... vs {b['file']} {b['sha256'][:12]}...)")
        if _observation_parts(first) != _observation_parts(pf):
            show = lambda p: ",".join(f"{n}({s})" for n, s in _observation_parts(p))
            raise UserError(f"{first.path} and {pf.path} observe differently: {show(first)} vs {show(pf)}")
        for key, value in first.manifest["control"].items():
            if pf.manifest["control"].get(key) != value:
                raise UserError(f"{first.path} and {pf.path} differ in control.{key} "
                                f"({value} vs {pf.manifest['control'].get(key)})")
    if not any(pf.clip().loop for pf in experts):
        raise UserError("compose needs at least one expert on a looping (locomotion) clip")


def _unique_names(names: list[str]) -> list[str]:
    out = []
    for n in names:
        out.append(n if n not in out else f"{n}#{sum(o.split('#')[0] == n for o in out) + 1}")
    return out


def check_temperature(temperature: float) -> float:
    """The gate's softmax temperature: below 0 it would prefer the experts that expect the least."""
    if not np.isfinite(temperature) or temperature < 0:
        raise UserError(f"--temperature {temperature}: must be >= 0 (0: always the highest value)")
    return float(temperature)


def compose(experts: list[PolicyFile], temperature: float = DEFAULT_TEMPERATURE) -> Composite:
    """A composite of exported experts (checked by `check_experts`)."""
    check_experts(experts)
    check_temperature(temperature)
    names = _unique_names([pf.clip().name for pf in experts])
    entries = []
    for name, pf in zip(names, experts, strict=True):
        clip = pf.manifest["clip"]
        entries.append({"name": name, "clip": clip["name"], "loop": bool(clip["loop"]),
                        "duration_s": clip["duration_s"], "source": str(pf.path),
                        "nr": (pf.manifest.get("training", {}).get("eval") or {}).get("nr"),
                        "manifest": pf.manifest})
    manifest = {"format": FORMAT, "format_version": FORMAT_VERSION, "mjxmimic_version": __version__,
                "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                "temperature": float(temperature),
                "character": {k: experts[0].manifest["character"][k] for k in ("file", "sha256")},
                "gate": ("every control step: softmax of each expert's value of its own observation / "
                         "temperature, sampled; no immediate repeat of a finished non-looping expert; "
                         "mjxmimic.envs.composite"),
                "experts": entries}
    return Composite(manifest=json.loads(json.dumps(manifest)), experts=list(experts))


def write(c: Composite, path: Path) -> Path:
    """Atomically (policy_file.save_arrays)."""
    arrays = {f"expert/{e}/{k}": v for e, pf in enumerate(c.experts) for k, v in pf.arrays().items()}
    arrays["manifest"] = np.array(json.dumps(c.manifest, indent=1))
    arrays["character_xml"] = np.array(c.experts[0].character_xml)
    c.path = policy_file.save_arrays(arrays, path)
    return c.path


def is_composite(path: Path) -> bool:
    """Whether `path` is a composite file (an npz whose manifest says so)."""
    path = Path(path)
    if not path.is_file() or path.suffix != ".npz":
        return False
    try:
        with np.load(path, allow_pickle=False) as z:
            return "manifest" in z.files and json.loads(str(z["manifest"])).get("format") == FORMAT
    except policy_file.UNREADABLE_NPZ:
        return False


def read(path: Path) -> Composite:
    path = Path(path)
    data = policy_file.load_arrays(path, "a composite file")
    try:
        manifest = json.loads(str(data["manifest"]))
    except (ValueError, KeyError) as err:
        raise UserError(f"{path}: cannot read as a composite file ({err})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise UserError(f"{path}: not a composite file (no '{FORMAT}' manifest)")
    if int(manifest.get("format_version", 0)) > FORMAT_VERSION:
        raise UserError(f"{path}: composite format version {manifest['format_version']} is newer than this "
                        f"mjxmimic reads ({FORMAT_VERSION}); update mjxmimic")
    xml = str(data["character_xml"])
    experts = []
    for e, entry in enumerate(manifest["experts"]):
        prefix = f"expert/{e}/"
        arrays = {k[len(prefix):]: v for k, v in data.items() if k.startswith(prefix)}
        experts.append(PolicyFile(manifest=entry["manifest"], params=policy_file.params_from_arrays(arrays),
                                  character_xml=xml, clip_qpos=arrays["clip/qpos"],
                                  clip_durations=arrays["clip/durations"], path=path))
    return Composite(manifest=manifest, experts=experts, path=path)


# ---------------------------------------------------------------------------------- CPU player


class Player:
    """The composite on MuJoCo's CPU simulator: one CpuEnv over every expert's clip, the gate
    before every step (mjxmimic.envs.composite.decide), the chosen expert's deterministic policy."""

    def __init__(self, c: Composite, temperature: float | None = None):
        self.composite = c
        self.env = CpuEnv(config_lib.playback_config(c.config()), c.character(), c.clips())
        self.env.terminations = COMPOSITE_TERMINATIONS
        self.gate = gate_lib.make_gate(self.env.spec, self.env.physics.kinematics,
                                       c.temperature if temperature is None else check_temperature(temperature))
        self.policies = [pf.policy() for pf in c.experts]
        self.values = [pf.value() for pf in c.experts]

    def values_of(self, obs: np.ndarray) -> np.ndarray:
        return np.array([v(o) for v, o in zip(self.values, obs, strict=True)])

    def reset(self, t: float, expert: int) -> None:
        self.env.reset_at(t, clip=expert)

    def step(self, u: float, external_force: Any = None, values_of: Callable[[np.ndarray], np.ndarray] | None = None,
             grade_paper: bool = False) -> tuple[Any, gate_lib.Decision]:
        """The gate's decision (on the experts' values, or `values_of`), then one control step of
        the chosen expert: (Step, Decision)."""
        env = self.env
        qpos, qvel = env.data.qpos.copy(), env.data.qvel.copy()
        d = gate_lib.decide(env.spec, self.gate, env.physics, qpos, qvel, env.motion, values_of or self.values_of,
                            np.float32(u))
        motion = gate_lib.switch(env.spec, env.motion, d, qpos, np)
        env.motion = motion._replace(clip=int(motion.clip), time=np.float32(motion.time))
        choice = int(d.choice)
        return env.step(self.policies[choice](d.obs[choice]), external_force=external_force,
                        grade_paper=grade_paper), d


def timeline(names: list[str], experts: list[int], dt: float) -> list[dict[str, Any]]:
    """Runs of one expert: name, from and to (s)."""
    out: list[dict[str, Any]] = []
    for k, e in enumerate(experts):
        if out and out[-1]["expert"] == names[e]:
            out[-1]["to_s"] = round((k + 1) * dt, 4)
        else:
            out.append({"expert": names[e], "from_s": round(k * dt, 4), "to_s": round((k + 1) * dt, 4)})
    return out


def play(c: Composite, seconds: float = 10.0, start: float = 0.0, expert: str | None = None,
         push: tuple[float, float, float] | None = None, seed: int = 0, temperature: float | None = None,
         on_step: Callable[[Player, Any, gate_lib.Decision], Any] | None = None) -> dict[str, Any]:
    """One run of the composite from the start expert's reference at `start`: which expert ran
    when, root height, and whether it ended standing. `push` (force N, time s, turn) as render's."""
    player = Player(c, temperature)
    env = player.env
    first = c.start_expert(expert)
    player.reset(start, first)
    steps = max(1, round(seconds / env.control_dt))
    u = np.random.default_rng(seed).uniform(size=steps)
    chosen, heights, bad = [], [], False
    for k in range(steps):
        force = None if push is None else \
            push_protocol.scheduled(env.data.qpos, push, k, env.control_dt, env.model.nbody, np)[0]
        s, d = player.step(u[k], force)
        chosen.append(int(d.choice))
        heights.append(float(d.root_height))
        if on_step is not None and on_step(player, s, d) is False:
            break
        if s.failed:  # a state the simulator lost
            bad = True
            break
    dt = env.control_dt
    shares = np.bincount(chosen, minlength=len(c.names)) / max(len(chosen), 1)
    stand = player.gate.stand_height
    return {"composite": str(c.path), "experts": c.names, "temperature": player.gate.temperature,
            "start_expert": c.names[first], "start_time": float(start), "seconds": len(chosen) * dt,
            "push": None if push is None else {"force_n": push[0], "at_s": push[1], "turn_rad": push[2]},
            "timeline": timeline(c.names, chosen, dt), "expert_share": dict(zip(c.names, map(float, shares))),
            "min_root_height_m": min(heights), "end_root_height_m": heights[-1],
            "standing_at_end": heights[-1] >= protocol.UP_FRACTION * stand, "lost_state": bad,
            "stand_height_m": stand}


def clip_nr(c: Composite, episodes: int = 8, seed: int = 0, temperature: float | None = None) -> dict[str, Any]:
    """Per expert clip, EVALUATION.md's NR protocol from RSI states of that clip twice over the same
    start times: with that clip's own expert forced (the value selector always picking it: its
    sim-to-sim NR) and with the gate choosing. Each step is graded against the active expert's
    clip and ends by its fall rule; the horizon is the start clip's. `kept` is the share of the
    gated steps in which the gate kept the clip's own expert."""
    from mjxmimic.task import nr as nr_rule
    from mjxmimic.task import termination

    player = Player(c, temperature)
    env = player.env
    env.terminations = termination.evaluation_list(True)
    rows: dict[str, Any] = {}
    for e, name in enumerate(c.names):
        duration = float(env.clip_durations[e]) - (0.0 if c.loops[e] else env.control_dt)
        starts = np.random.default_rng([seed, e]).uniform(0.0, max(duration, 0.0), size=episodes)
        own = np.where(np.arange(len(c.names)) == e, 0.0, -np.inf)
        row: dict[str, Any] = {}
        for mode, values_of in (("own", lambda obs, own=own: own), ("gate", None)):
            sums, horizons, kept, total = [], [], 0, 0
            u = np.random.default_rng([seed, e, 1]).uniform(size=(episodes, env.max_eval_horizon))
            for i, t0 in enumerate(starts):
                player.reset(float(t0), e)
                horizon = env.eval_horizon(float(t0), e)
                acc = nr_rule.start((), np)
                for k in range(horizon):
                    s, d = player.step(u[i, k], values_of=values_of, grade_paper=True)
                    kept, total = kept + (int(d.choice) == e), total + 1
                    m = s.metrics
                    acc = nr_rule.add_step(acc, k, horizon, m["reward/imitation"], m["reward_paper"], s.failed,
                                           s.clip_end, m["error/pose"], m["error/end_effector"], np)
                    if not acc["alive"]:
                        break
                sums.append({k: float(acc[k]) for k in nr_rule.FIELDS})
                horizons.append(horizon)
            summary = nr_rule.summarize({k: np.array([x[k] for x in sums]) for k in nr_rule.FIELDS},
                                        np.array(horizons), env.control_dt)
            row[f"nr_{mode}"], row[f"nr_paper_{mode}"] = summary["nr"], summary["nr_paper"]
            row[f"fall_rate_{mode}"] = summary["fall_rate"]
            if mode == "gate":
                row["kept"] = kept / max(total, 1)
        rows[name] = row
    return {"composite": str(c.path), "episodes": episodes, "seed": seed, "temperature": player.gate.temperature,
            "clips": rows}


def recovery_trial(player: Player, t0: float, expert: int, force_n: float, turn: float, u: np.ndarray,
                   n: protocol.Steps, on_step: Callable[[int, gate_lib.Decision], Any] | None = None,
                   ) -> tuple[protocol.State, np.ndarray]:
    """One knock-down trial on the CPU (mjxmimic.task.recovery): its final rule state and the steps
    each expert ran. Stops early once the outcome is known. `on_step(k, decision)` sees every step
    (a trace)."""
    env, gate = player.env, player.gate
    player.reset(t0, expert)
    state = protocol.start((), np)
    counts = np.zeros(len(player.policies), np.int64)
    for k in range(n.total):
        active = float(n.lead <= k < n.lead + n.push)
        force = push_protocol.wrench(env.data.qpos, force_n, turn, active, env.model.nbody, np)
        locomotion = bool(gate.loop[env.motion.clip])
        s, d = player.step(u[k], force)
        state = protocol.update(state, k, d.root_height, locomotion, d.pose_error, gate.stand_height, n, np)
        counts[int(d.choice)] += 1
        if on_step is not None:
            on_step(k, d)
        if s.failed or state.recovered_step >= 0 or state.up_at_push == 0:
            break
        if state.down_step < 0 and k >= n.lead + n.down_within:
            break
        if state.down_step >= 0 and k - state.down_step > n.recover:
            break
    return protocol.State(*(int(x) for x in state)), counts


def recovery_rate(c: Composite, knockdowns: int = 50, force_n: float = protocol.DEFAULT_FORCE_N,
                  direction: str = "random", seed: int = 0, max_trials: int | None = None,
                  expert: str | None = None, temperature: float | None = None,
                  progress: Callable[[int, int, int], Any] | None = None,
                  knocked_states: list[tuple[np.ndarray, np.ndarray]] | None = None) -> dict[str, Any]:
    """The recovery rate over the first `knockdowns` knock-downs, trials one after another on the
    CPU (at most `max_trials`, default 4 per knock-down asked). With a `knocked_states` list, the
    character's (qpos, qvel) after every KNOCKED_STATE_EVERY-th step of each knock-down, from going
    down until it is up again, is appended to it: states for getups to train from
    (`env.start_states`, mjxmimic.envs.start_bank)."""
    player = Player(c, temperature)
    first = c.start_expert(expert)
    n = protocol.steps(player.env.control_dt)
    limit = max_trials or 4 * knockdowns
    duration = float(player.env.clip_durations[first])
    up = protocol.UP_FRACTION * player.gate.stand_height
    nq, nv = player.env.physics.scene.nq, player.env.physics.scene.nv
    states, counts = [], []
    for i in range(limit):
        trial = protocol.draw_trials(seed, i, 1, duration, direction, n.total)
        rows: list = []
        record = None if knocked_states is None else (lambda k, d: rows.append(
            (player.env.data.qpos[:nq].copy(), player.env.data.qvel[:nv].copy(), float(d.root_height))))
        state, used = recovery_trial(player, float(trial.start_time[0]), first, force_n, float(trial.turn[0]),
                                     trial.u[0], n, record)
        if knocked_states is not None and state.down_step >= 0:
            for q, v, height in rows[state.down_step::KNOCKED_STATE_EVERY]:
                if height >= up:
                    break
                knocked_states.append((q, v))
        states.append(state)
        counts.append(used)
        knocked = sum(s.down_step >= 0 for s in states)
        if progress is not None:
            progress(i, knocked, sum(s.recovered_step >= 0 for s in states))
        if knocked >= knockdowns:
            break
    cols = protocol.State(*(np.array(x) for x in zip(*states)))
    out = protocol.summarize(cols.up_at_push, cols.down_step, cols.recovered_step, np.array(counts), c.names,
                             knockdowns, player.env.control_dt)
    return {"composite": str(c.path), "simulator": "mujoco (CPU)", "force_n": force_n, "direction": direction,
            "seed": seed, "start_expert": c.names[first], "temperature": player.gate.temperature, **out}
