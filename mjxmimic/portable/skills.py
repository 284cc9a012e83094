"""The skill selector at play time: `--skill-sequence "walk:4,run:4,walk:4"` switches the clip that a
policy trained on a dataset (with the skill one-hot in its observation) follows, without resetting
the character: between cyclic clips at once, at the same phase; into or out of a one-off clip (a
getup, a kick) where the playing cycle ends (CpuEnv.switch); with routes measured by the switch
trials, through a third skill where that holds more often. No JAX."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from mjxmimic.core.errors import UserError
from mjxmimic.envs.cpu_env import CpuEnv

Sequence = list[tuple[int, float]]  # (clip number, seconds)


def parse_sequence(text: str, names: list[str]) -> Sequence:
    """"walk:4,run:4" -> [(index of walk, 4.0), (index of run, 4.0)]; one-line errors."""
    out = []
    for part in text.split(","):
        name, sep, seconds = part.strip().rpartition(":")
        if not sep or not name:
            raise UserError(f"--skill-sequence {text!r}: expected SKILL:SECONDS[,SKILL:SECONDS ...], got {part!r}")
        if name not in names:
            raise UserError(f"--skill-sequence: unknown skill {name!r} (the policy's skills: {', '.join(names)})")
        try:
            value = float(seconds)
        except ValueError:
            value = float("nan")
        if not np.isfinite(value) or value <= 0:
            raise UserError(f"--skill-sequence: {part.strip()!r}: the seconds must be a positive number")
        out.append((names.index(name), value))
    return out


def check_selectable(env: CpuEnv) -> None:
    """A skill sequence needs several clips and a policy that sees which one it is to follow."""
    if len(env.clips) < 2:
        raise UserError("--skill-sequence needs a policy trained on a dataset of clips; this one has one clip")
    if "skill" not in env.config.env.observations.split(","):
        raise UserError("--skill-sequence: the policy does not observe a skill (it was trained without "
                        "env.observations=...,skill), so switching would change only the reference")


def skill_for_key(keycode: int, count: int) -> int | None:
    """The viewer's keys 1 to 9 pick skills 0 to 8 (of `count`); other keys pick none."""
    index = keycode - ord("1")
    return index if 0 <= index < min(count, 9) else None


def segment_steps(env: CpuEnv, sequence: Sequence) -> list[int]:
    """Control steps of each segment (at least one)."""
    return [max(1, round(seconds / env.control_dt)) for _, seconds in sequence]


def switch_steps(env: CpuEnv, sequence: Sequence) -> dict[int, int]:
    """{control step at which a segment starts: its clip number}."""
    starts = np.cumsum([0, *segment_steps(env, sequence)[:-1]])
    return {int(k): clip for k, (clip, _) in zip(starts, sequence, strict=True)}


def play_sequence(env: CpuEnv, policy: Callable[[np.ndarray], np.ndarray], sequence: Sequence,
                  on_step: Callable[[CpuEnv, Any], Any] | None = None) -> dict[str, Any]:
    """One run through the sequence from the first clip's start; per segment, how long the
    character stayed up and how well it tracked that segment's clip (mean imitation reward, pose
    error). It ends at a fall; the episode time limit does not apply."""
    check_selectable(env)
    obs = env.reset_at(0.0, clip=sequence[0][0])
    segments, fell = [], False
    for index, ((clip, seconds), steps) in enumerate(zip(sequence, segment_steps(env, sequence), strict=True)):
        if index > 0:
            obs = env.switch(clip)
        rewards, pose, started = [], [], None
        for k in range(steps):
            if started is None and env.motion.clip == clip:
                started = k * env.control_dt
            s = env.step(policy(obs))
            rewards.append(s.metrics["reward/imitation"])
            pose.append(s.metrics["error/pose"])
            obs = s.obs
            if on_step is not None:
                on_step(env, s)
            if s.failed:
                fell = True
                break
        segments.append({"skill": env.clips[clip].name, "seconds": seconds, "switched_after_s": started,
                         "survived_s": len(rewards) * env.control_dt,
                         "imitation_reward": float(np.mean(rewards)), "pose_error_rad": float(np.mean(pose))})
        if fell:
            break
    return {"segments": segments, "fell": fell, "survived_s": sum(s["survived_s"] for s in segments),
            "seconds": sum(s for _, s in sequence)}


def best_routes(trials: dict[str, Any], names: list[str],
                source: str = "the switch trials") -> dict[tuple[int, int], int]:
    """From `play --switch-trials N --json` output: for each ordered pair of skills (a, b), the skill c
    to pass through (CpuEnv.routes) where the measured rates make a -> c -> b likelier to hold than a
    -> b (the product of the two rates, as if independent)."""
    pairs = trials.get("pairs")
    if not isinstance(pairs, dict) or not pairs:
        raise UserError(f"{source}: no switch pairs (expected the JSON of "
                        "`mjxmimic play POLICY --switch-trials N --json`)")
    rate = {}
    for pair, row in pairs.items():
        a, sep, b = pair.partition(" -> ")
        if not sep or a not in names or b not in names:
            raise UserError(f"{source}: pair {pair!r} is not a switch between the policy's skills "
                            f"({', '.join(names)})")
        tried = row.get("steps_after_switch") if isinstance(row, dict) else None
        if not isinstance(tried, list) or not tried or not isinstance(row.get("held"), int):
            raise UserError(f"{source}: pair {pair!r} has no 'held' count of its 'steps_after_switch' trials")
        rate[names.index(a), names.index(b)] = row["held"] / len(tried)
    routes = {}
    for (a, b), direct in rate.items():
        via = max((c for c in range(len(names)) if c not in (a, b)),
                  key=lambda c: rate.get((a, c), 0.0) * rate.get((c, b), 0.0), default=None)
        if via is not None and rate.get((a, via), 0.0) * rate.get((via, b), 0.0) > direct:
            routes[a, b] = via
    return routes


def read_routes(path: Path, names: list[str]) -> dict[tuple[int, int], int]:
    """`--switch-routes TRIALS.json`: best_routes of a file that `--switch-trials N --json` wrote."""
    try:
        trials = json.loads(Path(path).read_text())
    except (OSError, ValueError) as e:
        raise UserError(f"--switch-routes {path}: cannot read it as JSON ({e.__class__.__name__})") from None
    if not isinstance(trials, dict):
        raise UserError(f"--switch-routes {path}: expected the JSON object of --switch-trials N --json")
    return best_routes(trials, names, f"--switch-routes {path}")


AIRBORNE_M = 0.2  # m: how high both feet of a clip's reference rise for `--finish-cycle auto` to wait for it


def airborne_skills(env: CpuEnv) -> set[int]:
    """The cyclic skills whose reference lifts both feet AIRBORNE_M or more off the ground at some
    frame (a backflip, a jump, a cartwheel), which a switch had better leave where they end."""
    from mjxmimic.motion.clip import lowest_points

    feet = env.character.body_sets.get("feet")
    if not feet:
        return set()
    return {i for i, clip in enumerate(env.clips)
            if clip.loop and float(lowest_points(env.character, clip.qpos, feet).max()) >= AIRBORNE_M}


def finish_cycle_skills(env: CpuEnv, text: str | None) -> set[int]:
    """`--finish-cycle`: skill names, 'none', or 'auto' (the default, None: airborne_skills)."""
    if text is None or text == "auto":
        return airborne_skills(env)
    if text == "none":
        return set()
    return read_skills(text, [c.name for c in env.clips], "--finish-cycle")


def set_switch_options(env: CpuEnv, switch_routes: Path | None, finish_cycle: str | None) -> None:
    """`--switch-routes` and `--finish-cycle` (play, render) onto the env's switches."""
    if switch_routes is not None:
        env.routes = read_routes(switch_routes, [c.name for c in env.clips])
    env.finish_cycle = finish_cycle_skills(env, finish_cycle)


def read_skills(text: str, names: list[str], flag: str) -> set[int]:
    """'backflip,run' -> the skills' numbers; an unknown name is a UserError naming `flag`."""
    picked = [n.strip() for n in text.split(",") if n.strip()]
    for name in picked or [""]:
        if name not in names:
            raise UserError(f"{flag} {text!r}: no skill {name!r} (the policy's skills: {', '.join(names)})")
    return {names.index(n) for n in picked}


def switch_trials(env: CpuEnv, policy: Callable[[np.ndarray], np.ndarray], moments: int = 10,
                  lead_s: float = 1.0, hold_s: float = 4.0) -> dict[str, Any]:
    """How often the selector's switches hold: for every ordered pair of skills (A, B), `moments`
    runs that play A from its start for lead_s plus 0, 4, 8, ... control steps, ask for B
    (CpuEnv.switch) and count the control steps from the switch to a fall; a switch holds when the
    character is still up hold_s after it (-1: it fell before the switch came)."""
    check_selectable(env)
    hold, lead = round(hold_s / env.control_dt), round(lead_s / env.control_dt)

    def trial(a: int, b: int, extra: int) -> int:
        obs = env.reset_at(0.0, clip=a)
        for _ in range(lead + extra):
            s = env.step(policy(obs))
            obs = s.obs
            if s.failed:
                return -1
        obs, after = env.switch(b), None
        for _ in range(env.max_steps + hold):
            if after is None and env.motion.clip == b:
                after = 0
            s = env.step(policy(obs))
            obs = s.obs
            if s.failed:
                return -1 if after is None else after
            if after is not None:
                after += 1
                if after == hold:
                    return hold
        return -1

    pairs = {}
    for a, b in ((a, b) for a in range(len(env.clips)) for b in range(len(env.clips)) if a != b):
        steps = [trial(a, b, 4 * k) for k in range(moments)]
        pairs[f"{env.clips[a].name} -> {env.clips[b].name}"] = {"held": sum(x == hold for x in steps),
                                                                "steps_after_switch": steps}
    routes = {f"{env.clips[a].name} -> {env.clips[b].name}": env.clips[c].name
              for (a, b), c in env.routes.items()}
    return {"pairs": pairs, "held": sum(p["held"] for p in pairs.values()), "trials": moments * len(pairs),
            "hold_s": hold_s, "lead_s": lead_s, "entry": env.config.env.skill_switch_entry, "routes": routes,
            "finish_cycle": sorted(env.clips[c].name for c in env.finish_cycle)}
