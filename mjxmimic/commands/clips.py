"""`mjxmimic clips`: list and inspect motion clips.

Each subcommand is a pair of functions, `add_<name>_arguments(parser)` and `run_<name>(args) -> int`,
registered in SUBCOMMANDS; adding one (e.g. `render`) is a new pair and a new entry. Heavy imports
belong inside the run function. This module and mjxmimic.motion.clip stay free of JAX.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from mjxmimic.commands import arg_types
from mjxmimic.core.errors import UserError

if TYPE_CHECKING:
    from mjxmimic.core.character import Character


class Subcommand(NamedTuple):
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]


def _add_clips_dir(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--clips-dir", metavar="DIR", default=None,
                        help="folder of clip files searched after the project's clips/ "
                             "(default: $MJXMIMIC_CLIPS, folders separated by the path separator)")
    parser.add_argument("--character", default="humanoid", metavar="NAME|PATH",
                        help="the character the clips move: humanoid (default), dog3d, g1, or an MJCF file; "
                             "its clip prefix finds clips by short name (dog3d: trot -> dog3d_trot.txt)")


def _character(args: argparse.Namespace) -> Character:
    from mjxmimic.core.character import load_character, resolve_xml

    return load_character(resolve_xml(args.character))


# ------------------------------------------------------------------------------------------ list


def add_list_arguments(parser: argparse.ArgumentParser) -> None:
    _add_clips_dir(parser)


def run_list(args: argparse.Namespace) -> int:
    from mjxmimic.core.character import character_for_clip
    from mjxmimic.motion.clip import list_clips, search_folders

    clips = list_clips(args.clips_dir, _character(args).clip_prefix)
    if not clips:
        where = ", ".join(str(folder) for _, folder in search_folders(args.clips_dir))
        print(f"no clips found (looked in: {where})")
        return 0
    width = max(len(name) for name, _, _ in clips)
    swidth = max(len(label) for _, _, label in clips)
    print(f"{'clip':<{width}}  {'source':<{swidth}}  {'fits':<8}  file")
    for name, path, label in clips:
        print(f"{name:<{width}}  {label:<{swidth}}  {character_for_clip(path):<8}  {path}")
    return 0


# ------------------------------------------------------------------------------------------ info


def add_info_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("clip", metavar="NAME|PATH", help="a clip name (see `mjxmimic clips list`), a clip file, "
                        "or a dataset file (.json/.yaml with a list under \"clips\")")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    _add_clips_dir(parser)


def clip_summary(clip, character) -> dict:
    """The numbers `clips info` shows, as a JSON-ready dict."""
    from mjxmimic.motion.clip import lowest_points
    from mjxmimic.motion.flight import flights

    feet = character.body_sets.get("feet")
    lowest = lowest_points(character, clip.qpos)
    summary = {
        "valid": True,
        "error": None,
        "name": clip.name,
        "path": str(clip.path) if clip.path is not None else None,
        "frames": clip.num_frames,
        "duration_s": round(clip.duration, 6),
        "loop": clip.loop_mode,
        "fps": round(clip.fps, 4),
        "root_travel_m": round(clip.root_travel, 4),
        "mean_speed_mps": round(clip.mean_speed, 4),
        "root_path_m": round(clip.root_path, 4),
        "path_speed_mps": round(clip.root_path / clip.duration, 4),
        "heading_change_deg": round(math.degrees(clip.heading_change), 2),
        "root_height_m": [round(float(clip.root_pos[:, 2].min()), 4),
                          round(float(clip.root_pos[:, 2].max()), 4)],
        "lowest_point_m": [round(float(lowest.min()), 4), round(float(lowest.max()), 4)],
        "max_quat_norm_error": round(clip.max_quat_norm_error, 4),
        "gravity_mps2": round(float(-character.model.opt.gravity[2]), 4),
        "flights": [f.as_dict() for f in flights(character, clip)],
    }
    if feet:
        soles = lowest_points(character, clip.qpos, feet)
        summary["lowest_sole_m"] = [round(float(soles.min()), 4), round(float(soles.max()), 4)]
    return summary


def _print_summary(s: dict) -> None:
    from mjxmimic.motion.flight import describe

    rows = [
        ("clip", s["name"]),
        ("path", s["path"]),
        ("frames", s["frames"]),
        ("duration", f"{s['duration_s']:.3f} s"),
        ("loop", s["loop"]),
        ("frame rate", f"{s['fps']:.2f} fps"),
        ("root travel", f"{s['root_travel_m']:.3f} m from first to last frame, {s['root_path_m']:.3f} m along "
                        f"its path (heading change {s['heading_change_deg']:.1f} deg)"),
        ("mean speed", f"{s['mean_speed_mps']:.3f} m/s first to last, {s['path_speed_mps']:.3f} m/s along the path"),
        ("root height", "{:.3f} .. {:.3f} m".format(*s["root_height_m"])),
        ("lowest point", "{:.3f} .. {:.3f} m over frames (0 = floor)".format(*s["lowest_point_m"])),
    ]
    if "lowest_sole_m" in s:
        rows.append(("lowest sole", "{:.3f} .. {:.3f} m".format(*s["lowest_sole_m"])))
    for flight in s["flights"]:
        rows.append(("airborne", describe(flight, s["gravity_mps2"])))
    if s["max_quat_norm_error"] > 1e-6:
        rows.append(("quaternions", f"normalised on load (file off by up to {s['max_quat_norm_error']:.3f})"))
    rows.append(("verdict", "valid"))
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")


def _run_dataset_info(args: argparse.Namespace, character) -> int:
    """A dataset: each clip's duration, loop mode, speed and its share of the RSI draws."""
    from mjxmimic.motion.dataset import load_dataset

    data = load_dataset(args.clip, character, args.clips_dir)
    total = sum(data.weights)
    rows = [{"name": c.name, "path": str(c.path), "weight": w, "share": w / total,
             "duration_s": round(c.duration, 6), "loop": c.loop_mode, "mean_speed_mps": round(c.mean_speed, 4),
             "heading_change_deg": round(math.degrees(c.heading_change), 2)}
            for c, w in zip(data.clips, data.weights)]
    if args.json:
        print(json.dumps({"dataset": str(data.path), "clips": rows}))
        return 0
    print(f"{data.path}: {len(rows)} clips")
    width = max(len(r["name"]) for r in rows)
    for r in rows:
        print(f"  {r['name']:<{width}}  weight {r['weight']:g} ({r['share']:.0%} of the starts), "
              f"{r['duration_s']:.2f} s, {r['loop']}, {r['mean_speed_mps']:.2f} m/s, "
              f"turns {r['heading_change_deg']:.0f} deg")
    return 0


def run_info(args: argparse.Namespace) -> int:
    from mjxmimic.motion.clip import ClipError, load_clip_source
    from mjxmimic.motion.dataset import is_dataset

    character = _character(args)
    if is_dataset(args.clip):
        return _run_dataset_info(args, character)
    try:
        clip = load_clip_source(args.clip, character, args.clips_dir)
    except ClipError as err:
        if args.json:
            print(json.dumps({"clip": args.clip, "valid": False, "error": str(err)}))
        else:
            print(f"mjxmimic clips info: invalid: {err}", file=sys.stderr)
        return 2
    summary = clip_summary(clip, character)
    if args.json:
        print(json.dumps(summary))
    else:
        _print_summary(summary)
    return 0


# ---------------------------------------------------------------------------------------- render


def add_render_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("clip", metavar="NAME|PATH", help="a clip name (see `mjxmimic clips list`) or a file")
    parser.add_argument("--out", type=arg_types.path, metavar="FILE.mp4", default=None, help="video file (default: NAME.mp4)")
    parser.add_argument("--seconds", type=float, default=None, help="length (default: the clip's duration)")
    parser.add_argument("--fps", type=float, default=30.0, help="frames per second (default 30)")
    parser.add_argument("--width", type=int, default=640, help="video width in pixels (a multiple of 16)")
    parser.add_argument("--height", type=int, default=480, help="video height in pixels (a multiple of 16)")
    _add_clips_dir(parser)


def run_render(args: argparse.Namespace) -> int:
    """Headless video of the clip's reference motion (kinematic; mjxmimic.portable.render)."""
    from mjxmimic.commands.render import _check_size
    from mjxmimic.portable.render import check_video_path, render_clip, setup_gl

    _check_size(args.width, args.height)
    if args.out is not None:
        check_video_path(Path(args.out))
    if args.seconds is not None and args.seconds <= 0:
        raise UserError(f"--seconds {args.seconds}: must be positive")
    if args.fps <= 0:
        raise UserError(f"--fps {args.fps}: must be positive")
    setup_gl()
    from mjxmimic.motion.clip import load_clip_source

    character = _character(args)
    clip = load_clip_source(args.clip, character, args.clips_dir)
    out = Path(args.out) if args.out is not None else Path(f"{clip.name}.mp4")
    info = render_clip(character, clip, out, seconds=args.seconds, fps=args.fps, width=args.width,
                       height=args.height)
    print(f"{out}: {info['frames']} frames, {info['seconds']:.2f} s at {info['fps']:g} fps, "
          f"{out.stat().st_size / 1024:.0f} KiB (MUJOCO_GL={info['gl']})")
    return 0


# ---------------------------------------------------------------------------------------- import


def add_import_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE.bvh", help="motion capture file (BVH)")
    parser.add_argument("--out", type=arg_types.path, metavar="FILE", required=True, help="clip file to write (DeepMimic's format)")
    parser.add_argument("--character", default="humanoid", metavar="NAME|PATH",
                        help="the character to move (default: humanoid; one that no mapping names, e.g. g1, "
                             "through the humanoid and mjxmimic/motion/retargets/)")
    parser.add_argument("--mapping", metavar="FILE.json", default=None,
                        help="skeleton mapping file (default: the shipped one whose joint names the file has, "
                             "see mjxmimic/motion/skeletons/; else, for the humanoid, one guessed from "
                             "the joint names and the rest pose)")
    parser.add_argument("--start", type=float, default=0.0, help="first second of the recording to keep (default 0)")
    parser.add_argument("--end", type=float, default=None, help="last second to keep (default: its end)")
    parser.add_argument("--fps", type=float, default=60.0, help="frame rate of the clip (default 60)")
    parser.add_argument("--loop", choices=("wrap", "none"), default="none",
                        help="wrap: the clip repeats (a gait cycle); none (default): it plays once")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")


def run_import(args: argparse.Namespace) -> int:
    """BVH -> a validated clip file, written only when it reads back as one (mjxmimic.motion.bvh_import).
    A character that no skeleton mapping names (the G1) gets the motion through the humanoid: imported
    onto it, then retargeted as `clips retarget` does."""
    from mjxmimic.core.character import load_character, resolve_xml
    from mjxmimic.motion.bvh import load_bvh
    from mjxmimic.motion.bvh_import import find_mapping, import_bvh, load_mapping, mapped_characters
    from mjxmimic.motion.clip import format_clip
    from mjxmimic.motion.retarget import find_map, retarget

    out = _check_out(Path(args.out))
    character = _character(args)
    name = Path(character.xml_path).stem
    via = None
    if args.mapping is None and name not in mapped_characters():
        try:
            retarget_map = find_map("humanoid", name)
        except UserError:
            raise UserError(f"no skeleton mapping moves {name} (mjxmimic/motion/skeletons/), nor a retarget file from "
                            f"the humanoid (mjxmimic/motion/retargets/); write a mapping like cmu_max.json and pass "
                            f"--mapping") from None
        via = load_character(resolve_xml("humanoid"))
    bvh = load_bvh(args.file)
    first = via or character
    first_name = Path(first.xml_path).stem
    mapping = load_mapping(Path(args.mapping), first_name) if args.mapping else find_mapping(bvh, first_name)
    result = import_bvh(bvh, first, mapping, start=args.start, end=args.end, fps=args.fps,
                        loop=args.loop == "wrap", name=out.stem)
    imported = {"clip": str(out), "source": str(args.file), **result.report}
    if mapping.path is None:  # guessed: shown, and given as a file to save and edit
        imported["mapping_file"] = mapping.as_file(first_name)
    report, clip, how = imported, result.clip, f"{mapping.label}, {args.start:g} to {result.report['end_s']:g} s"
    if via is not None:
        moved = retarget(result.clip, via, character, retarget_map)
        clip, how = moved.clip, f"{how}, through the humanoid ({moved.report['method']})"
        report = {"clip": str(out), "source": str(args.file), "via": first_name, "import": imported, **moved.report}
    text = format_clip(clip, character, comment=f"imported from {Path(args.file).name} by mjxmimic clips import "
                       f"({how})")
    _write_clip(text, out, character)
    if args.json:
        print(json.dumps(report))
        return 0
    print(f"{out}: {report['frames']} frames at {report['fps']:g} fps, {report['duration_s']:.2f} s "
          f"(from {imported['source_frames']} at {imported['source_fps']:.0f} fps, {imported['start_s']:g} to "
          f"{imported['end_s']:.2f} s), loop {args.loop}")
    print(f"  mapping {mapping.label}, scale {imported['scale']:.4f} m per unit, moved "
          f"{imported['ground_shift_m']:+.3f} m to the ground")
    calibration = imported["calibration"]
    if isinstance(calibration, dict):
        print(f"  its rest pose does not stand: bones matched at frame {calibration['frame']} "
              f"({calibration['time_s']:.2f} s), {calibration['bone_angle_rad']:.2f} rad from the character's "
              f"rest pose")
    if mapping.path is None:
        pairs = ", ".join(f"{body} {joint}" for body, joint in mapping.bodies.items())
        axes = imported["mapping_file"]
        print(f"  guessed: {pairs}; up {axes['up']}, facing {axes['forward']} "
              f"(--json gives it as a mapping file, to edit and pass with --mapping)")
    _print_quality(imported, "to the scaled source about the hips")
    if via is not None:
        print(f"  then {first_name} -> {name}: inverse kinematics ({Path(report['map']).name}), scale "
              f"{report['scale']:.3f}, moved {report['ground_shift_m']:+.3f} m to the ground")
        _print_quality(report, "to the scaled humanoid, about the root")
    return 0


def _check_out(out: Path) -> Path:
    """--out of a clip to write: a file name in a folder that exists (checked before the work)."""
    if out.is_dir():
        raise UserError(f"--out {out}: is a folder; give the clip file's name")
    if not out.parent.is_dir():
        raise UserError(f"--out {out}: no folder {out.parent}")
    return out


def _write_clip(text: str, out: Path, character: Character) -> None:
    """Write a made clip only once it reads back as one, and atomically."""
    from mjxmimic.motion.clip import clip_from_json

    clip_from_json(json.loads(text), character, out, out.stem)
    tmp = out.with_name(out.name + ".tmp")  # (out checked by the caller, before the work)
    tmp.write_text(text)
    tmp.replace(out)


def _print_quality(report: dict, about: str) -> None:
    errors = ", ".join(f"{k} {v * 100:.1f}" for k, v in report["end_effector_error_m"].items()) or "-"
    print(f"  end-effector error (cm, {about}): {errors}")
    skating = report["foot_skating_m_per_s"]
    print(f"  foot skating {'-' if skating is None else f'{skating:.3f} m/s'} (planted feet), penetration "
          f"{report['penetration_max_m'] * 100:.1f} cm, {report['frames_below_ground']} frames below ground, "
          f"joint-limit hits {report['joint_limit_hits']} ({report['joint_limit_hit_rate'] * 100:.1f} % of hinge samples)")
    stretches = report["airborne"]
    if not stretches:
        print("  never airborne (always within 2 cm of the ground)")
        return
    odd = [f for f in stretches if not f["ballistic"]]
    seconds = sum(f["end_s"] - f["start_s"] for f in odd)
    print(f"  {len(stretches)} airborne stretches (nothing within 2 cm of the ground), {len(odd)} of them held up or "
          f"turned with nothing touching ({seconds:.2f} s; `mjxmimic clips info` on the clip lists them)")


# -------------------------------------------------------------------------------------- retarget


def add_retarget_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("clip", metavar="CLIP", help="clip name or file of the source character")
    parser.add_argument("--to", required=True, metavar="NAME|PATH", help="the character to move (e.g. g1)")
    parser.add_argument("--out", type=arg_types.path, metavar="FILE", required=True, help="clip file to write (DeepMimic's format)")
    parser.add_argument("--from", dest="character", default="humanoid", metavar="NAME|PATH",
                        help="the clip's character (default: humanoid)")
    parser.add_argument("--map", metavar="FILE.json", default=None,
                        help="body pairs and weights (default: mjxmimic/motion/retargets/FROM_to_TO.json; not "
                             "needed when the skeletons match)")
    parser.add_argument("--clips-dir", default=None, metavar="DIR", help="folder of clips to look in first")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")


def run_retarget(args: argparse.Namespace) -> int:
    """A clip of one character -> a validated clip of another (mjxmimic.motion.retarget)."""
    from mjxmimic.core.character import load_character, resolve_xml
    from mjxmimic.motion.clip import format_clip, load_clip_source
    from mjxmimic.motion.retarget import find_map, load_map, matching, retarget

    out = _check_out(Path(args.out))
    source = _character(args)
    target = load_character(resolve_xml(args.to))
    clip = load_clip_source(args.clip, source, args.clips_dir)
    mapping = None
    if args.map:
        mapping = load_map(Path(args.map))
    elif not matching(source, target):
        mapping = find_map(source.xml_path.stem, target.xml_path.stem)
    result = retarget(clip, source, target, mapping)
    report = {"clip": str(out), "source": args.clip, "from": source.xml_path.stem, "to": target.xml_path.stem,
              **result.report}
    _write_clip(format_clip(result.clip, target, comment=f"retargeted from {args.clip} ({report['from']}) to "
                            f"{report['to']} by mjxmimic clips retarget ({report['method']})"), out, target)
    if args.json:
        print(json.dumps(report))
        return 0
    how = "joint rotations copied" if report["method"] == "copy" else f"inverse kinematics ({Path(report['map']).name})"
    print(f"{out}: {report['frames']} frames at {report['fps']:g} fps, {report['duration_s']:.2f} s, "
          f"{report['from']} -> {report['to']}, {how}, scale {report['scale']:.3f}, moved "
          f"{report['ground_shift_m']:+.3f} m to the ground")
    _print_quality(report, "to the scaled source, about the root")
    return 0


# ------------------------------------------------------------------------------------ dispatcher


SUBCOMMANDS: dict[str, Subcommand] = {
    "list": Subcommand("list the clips that can be given by name", add_list_arguments, run_list),
    "info": Subcommand("frames, duration, loop, rate, travel, validity and free fall in the air of a clip",
                       add_info_arguments, run_info),
    "render": Subcommand("headless video (mp4) of a clip's reference motion", add_render_arguments, run_render),
    "import": Subcommand("a motion capture file (BVH) -> a clip for a character", add_import_arguments, run_import),
    "retarget": Subcommand("a clip of one character -> a clip of another (e.g. --to g1)", add_retarget_arguments,
                           run_retarget),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="clips_command", metavar="SUBCOMMAND", required=True)
    for name, cmd in SUBCOMMANDS.items():
        cmd.add_arguments(sub.add_parser(name, help=cmd.help, description=cmd.help))


def run(args: argparse.Namespace) -> int:
    command = SUBCOMMANDS.get(args.clips_command)
    if command is None:  # only reachable when called without the parser
        raise UserError(f"unknown clips subcommand {args.clips_command!r}")
    return command.run(args)
