"""`mjxmimic render RUN|POLICY --out FILE.mp4 [--ghost]`: a headless video of a policy.

One episode on MuJoCo's CPU simulator (as `mjxmimic play` runs it) from the reference state at
--start, one frame per control step, until the episode ends or --seconds pass; --ghost adds the
reference motion as a translucent copy of the character (a RUN folder without policy.npz renders
its best checkpoint, or --checkpoint); --push FORCE@TIME pushes the pelvis for
0.2 s (the push test's push, a red arrow in the video) to show the recovery. POLICY is an exported file; a RUN folder
uses RUN/policy.npz, or its latest checkpoint when there is none (that path imports JAX).
A composite file (`mjxmimic compose`) renders --seconds (default 10) of the gate's play from
--expert, with the active expert's name on every frame: `--push 600@2` shows a knock-down, the
getup and the walk again.
Rendering is offscreen: EGL or OSMesa (mjxmimic.portable.render says which packages); videos need the
"render" extra (imageio, imageio-ffmpeg).
"""

from __future__ import annotations

import argparse

from mjxmimic.commands import arg_types, character_option
from mjxmimic.runs import folder


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("source", type=arg_types.path, metavar="RUN|POLICY", help="run folder or exported policy file")
    parser.add_argument("--out", type=arg_types.path, required=True, metavar="FILE.mp4",
                        help="video file to write (.png: a strip of 8 frames spread over the episode)")
    parser.add_argument("--ghost", action=argparse.BooleanOptionalAction, default=False,
                        help="show the reference motion as a translucent ghost")
    parser.add_argument("--clip", metavar="NAME|PATH", help="another clip (default: the policy's own)")
    character_option.add_option(parser)
    parser.add_argument("--clips-dir", metavar="DIR", default=None, help="extra folder for clip names")
    parser.add_argument("--start", type=float, default=0.0, help="clip time of the first frame (s)")
    parser.add_argument("--seconds", type=float, default=None,
                        help="at most this long (default: until the episode ends, at most env.episode_seconds)")
    parser.add_argument("--width", type=int, default=640, help="video width in pixels (a multiple of 16)")
    parser.add_argument("--height", type=int, default=480, help="video height in pixels (a multiple of 16)")
    parser.add_argument("--checkpoint", default="best", metavar="best|latest|N",
                        help="for a RUN folder without policy.npz: which checkpoint (default: the best)")
    parser.add_argument("--push", metavar="FORCE@TIME",
                        help="push the pelvis with FORCE newtons for 0.2 s from TIME seconds into the episode")
    parser.add_argument("--push-direction", choices=["forward", "sideways", "backward"], default="forward",
                        help="along the character's facing, to its left, or against its facing (default forward)")
    parser.add_argument("--expert", metavar="NAME", default=None,
                        help="a composite file: the expert to start in (default: the first looping one)")
    parser.add_argument("--skill-sequence", metavar="SKILL:SECONDS,...", default=None,
                        help="a dataset policy with the skill observation: switch skills, e.g. \"walk:4,run:4\"")
    parser.add_argument("--switch-routes", type=arg_types.path, default=None, metavar="TRIALS.json",
                        help="with --skill-sequence: route switches as `mjxmimic play --switch-routes` does")
    parser.add_argument("--finish-cycle", metavar="SKILL[,SKILL]|auto|none", default=None,
                        help="with --skill-sequence: switches out of these skills wait for their cycle's end, "
                             "as `mjxmimic play --finish-cycle` does (default auto)")


def parse_push(text: str, direction: str, flag: str = "--push") -> tuple[float, float, float]:
    """'300@1.5' -> (300 N, at 1.5 s, the direction's turn from the facing)."""
    from mjxmimic.core.errors import UserError
    from mjxmimic.task.recovery import DIRECTIONS

    try:
        force, at = (float(part) for part in text.split("@"))
    except ValueError:
        raise UserError(f"{flag} {text!r}: expected FORCE@TIME, e.g. 300@1.5 (newtons, seconds)") from None
    if not (0 <= force < float("inf") and 0 <= at < float("inf")):
        raise UserError(f"{flag} {text!r}: force and time must be finite and >= 0")
    return force, at, DIRECTIONS[direction]


def _check_size(width: int, height: int) -> None:
    from mjxmimic.core.errors import UserError

    for name, v in (("--width", width), ("--height", height)):
        if v < 16 or v % 16:
            raise UserError(f"{name} {v}: must be a positive multiple of 16 (video encoding)")


def _render_composite(args: argparse.Namespace, c, push) -> int:
    from mjxmimic.portable.render import render_composite

    info = render_composite(c, args.out, ghost=args.ghost, seconds=args.seconds or 10.0, start=args.start,
                            expert=args.expert, push=push, width=args.width, height=args.height)
    print(f"{args.out}: {info['frames']} frames, {info['seconds']:.1f} s at {info['fps']:.0f} fps, "
          f"{args.out.stat().st_size / 1024:.0f} KiB; experts: "
          + ", ".join(f"{seg['expert']} {seg['from_s']:.1f}-{seg['to_s']:.1f} s" for seg in info["timeline"][:12])
          + (" ..." if len(info["timeline"]) > 12 else "") + f" (MUJOCO_GL={info['gl']})")
    return 0


def run(args: argparse.Namespace) -> int:
    character_option.check(args.character, args.source)
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable.render import check_video_path, render_policy, setup_gl

    _check_size(args.width, args.height)
    push = None if args.push is None else parse_push(args.push, args.push_direction)
    check_video_path(args.out)
    if args.seconds is not None and args.seconds <= 0:
        raise UserError(f"--seconds {args.seconds}: must be positive")
    setup_gl()  # before anything imports mujoco, where possible
    from mjxmimic.portable import composite

    if composite.is_composite(args.source):
        return _render_composite(args, composite.read(args.source), push)
    pf = folder.load_policy_file(args.source, export_if_missing=True, checkpoint=args.checkpoint)
    clip = None
    if args.clip is not None:
        from mjxmimic.motion.clip import load_clip_source

        clip = load_clip_source(args.clip, pf.character(), args.clips_dir)
    info = render_policy(pf, args.out, ghost=args.ghost, clip=clip, start=args.start, seconds=args.seconds,
                         width=args.width, height=args.height, push=push, skill_sequence=args.skill_sequence,
                         switch_routes=args.switch_routes, finish_cycle=args.finish_cycle)
    end = "fell" if info["fell"] else "did not fall"
    print(f"{args.out}: {info['frames']} frames, {info['seconds']:.1f} s at {info['fps']:.0f} fps, "
          f"{args.out.stat().st_size / 1024:.0f} KiB; {args.skill_sequence or info['clip']} from "
          f"t={info['start_time']:.2f} s, "
          f"{end}, mean reward {info['mean_reward']:.3f} (MUJOCO_GL={info['gl']})")
    return 0
