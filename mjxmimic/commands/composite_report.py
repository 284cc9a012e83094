"""Argument checks and printing for composite files, shared by `mjxmimic play` (MuJoCo on the CPU)
and `mjxmimic eval` (MJX): one run with its expert timeline, or the recovery rate."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def check_knockdowns(args: argparse.Namespace) -> tuple[float, str]:
    """(force, direction) of a recovery evaluation, checked."""
    from mjxmimic.core.errors import UserError
    from mjxmimic.task import recovery

    if args.knockdowns < 1:
        raise UserError(f"--knockdowns {args.knockdowns}: must be at least 1")
    force = recovery.DEFAULT_FORCE_N if args.force is None else args.force
    if not 0 < force < float("inf"):  # nan too
        raise UserError(f"--force {force}: must be positive and finite")
    return force, args.push_direction or "random"


def print_recovery(result: dict[str, Any], as_json: bool) -> None:
    if as_json:
        print(json.dumps(result, indent=1))
        return
    rate = result["recovery_rate"]
    print(f"{result['composite']}: {result['simulator']}, {result['force_n']:.0f} N {result['direction']} pushes "
          f"on the pelvis for 0.2 s while in {result['start_expert']} (seed {result['seed']}, "
          f"temperature {result['temperature']:g})")
    short = "" if result["knockdowns"] >= result["knockdowns_asked"] else (
        f" (asked {result['knockdowns_asked']}; {result['trials']} trials were the limit)")
    print(f"  knock-downs          {result['knockdowns']} in {result['trials']} trials "
          f"({result['not_knocked_down']} stayed up, {result['fell_before_push']} fell before the push){short}")
    if rate is not None:
        mean = result["recovery_s_mean"]
        print(f"  recovered within 5 s {result['recovered']} of {result['knockdowns']}: {100 * rate:.0f} %"
              + ("" if mean is None else f", on its feet and tracking after {mean:.2f} s on average"))
    print("  expert time share    " + ", ".join(f"{n} {100 * s:.0f} %" for n, s in result["expert_share"].items()))
    if "saved_states" in result:
        print(f"  saved                {result['saved_states']['states']} knocked-down states to "
              f"{result['saved_states']['file']}")


def _save_states(path: Path, states: list) -> int:
    """Writes (qpos, qvel) rows as env.start_states reads them, whole or not at all; their count."""
    import numpy as np

    from mjxmimic.core.errors import UserError
    from mjxmimic.portable.policy_file import save_arrays

    if not states:
        raise UserError(f"--save-states {path}: no knock-down left a state to save")
    try:
        save_arrays({"qpos": np.array([q for q, _ in states], np.float32),
                     "qvel": np.array([v for _, v in states], np.float32)}, path)
    except OSError as e:
        raise UserError(f"--save-states {path}: cannot write it ({e.strerror})") from None
    return len(states)


def play(args: argparse.Namespace, c) -> int:
    """`mjxmimic play COMPOSITE`: one run with its timeline, or --knockdowns N on the CPU."""
    from mjxmimic.commands.render import parse_push
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable import composite

    for flag, given in (("--viewer", args.viewer), ("--push", args.push), ("--clip", args.clip is not None),
                        ("--skill-sequence", args.skill_sequence is not None)):
        if given:
            raise UserError(f"{flag} is for single policies; a composite plays with --push-once, --knockdowns "
                            f"or --episodes")
    if args.save_states is not None and (args.knockdowns is None or args.save_states.suffix != ".npz"):
        raise UserError(f"--save-states {args.save_states}: needs --knockdowns, and a file name ending in .npz")
    if args.save_states is not None and not args.save_states.parent.is_dir():
        raise UserError(f"--save-states {args.save_states}: no folder {args.save_states.parent}")
    if args.knockdowns is not None:
        force, direction = check_knockdowns(args)
        say = None if args.json else (lambda i, k, r: print(f"  trial {i + 1}: {k} knock-downs, {r} recovered",
                                                            file=sys.stderr, flush=True))
        knocked: list | None = None if args.save_states is None else []
        result = composite.recovery_rate(c, args.knockdowns, force, direction, 0 if args.seed is None else args.seed,
                                         expert=args.expert, temperature=args.temperature, progress=say,
                                         knocked_states=knocked)
        if knocked is not None:
            result["saved_states"] = {"file": str(args.save_states), "states": _save_states(args.save_states, knocked)}
        print_recovery(result, args.json)
        return 0
    if args.episodes is not None:
        if args.episodes < 1:
            raise UserError(f"--episodes {args.episodes}: must be at least 1")
        result = composite.clip_nr(c, args.episodes, 0 if args.seed is None else args.seed, args.temperature)
        if args.json:
            print(json.dumps(result, indent=1))
            return 0
        print(f"{c.path}: NR per clip from its own RSI states, {args.episodes} episodes each, MuJoCo CPU "
              f"(own: the clip's expert always; gate: the composite; temperature {result['temperature']:g})")
        print(f"  {'clip':<20} {'NR own':>7} {'NR gate':>8} {'falls own':>9} {'falls gate':>10} {'kept':>5}")
        for name, r in result["clips"].items():
            print(f"  {name:<20} {r['nr_own']:>7.3f} {r['nr_gate']:>8.3f} {r['fall_rate_own']:>9.2f} "
                  f"{r['fall_rate_gate']:>10.2f} {100 * r['kept']:>4.0f}%")
        return 0
    seconds = 10.0 if args.seconds is None else args.seconds
    if seconds <= 0:
        raise UserError(f"--seconds {seconds:g}: must be positive")
    direction = args.push_direction or "forward"
    if direction == "random":
        raise UserError("--push-direction random is for --knockdowns; --push-once takes a fixed direction")
    push = None
    if args.push_once is not None:
        from mjxmimic.task.recovery import DIRECTIONS

        force, at, _ = parse_push(args.push_once, "forward", "--push-once")
        push = (force, at, DIRECTIONS[direction])
    out = composite.play(c, seconds, args.start or 0.0, args.expert, push, 0 if args.seed is None else args.seed,
                         args.temperature)
    if args.json:
        print(json.dumps(out))
        return 0
    pushed = "" if push is None else f", pushed {push[0]:.0f} N {direction} at {push[1]:g} s"
    print(f"{c.path}: {out['seconds']:.1f} s from {out['start_expert']} at t={out['start_time']:g} s{pushed}, "
          f"MuJoCo CPU, gate temperature {out['temperature']:g}")
    for seg in out["timeline"]:
        print(f"  {seg['from_s']:6.2f} - {seg['to_s']:6.2f} s  {seg['expert']}")
    print(f"  root height: lowest {out['min_root_height_m']:.2f} m, at the end {out['end_root_height_m']:.2f} m "
          f"({'standing' if out['standing_at_end'] else 'not standing'}; standing height "
          f"{out['stand_height_m']:.2f} m)")
    return 0
