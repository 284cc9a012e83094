"""`mjxmimic export RUN [--out FILE] [--format npz|onnx] [--checkpoint best|latest|N]`: a run's
policy as one portable file.

Reads RUN/config.json, the checkpoint of the run's best evaluation (RUN/best; --checkpoint picks
the latest or another kept one) and its evaluation (RUN/best.json, else RUN/eval.json),
and writes RUN/policy.npz (or --out): network weights, observation normaliser, the character
MJCF and the clip, and a manifest (mjxmimic.portable.policy_file documents every key).
`mjxmimic play` and `mjxmimic render` need nothing else. ONNX (--format onnx) needs `onnx`.
"""

from __future__ import annotations

import argparse
import json

from mjxmimic.commands import arg_types, character_option


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run_dir", type=arg_types.path, metavar="RUN", help="run folder")
    parser.add_argument("--out", type=arg_types.path, metavar="FILE", help="output file (default: RUN/policy.npz or .onnx)")
    parser.add_argument("--format", choices=("npz", "onnx"), default=None,
                        help="file format (default: from --out's suffix, else npz)")
    parser.add_argument("--json", action="store_true", help="print the manifest as JSON")
    character_option.add_option(parser)
    parser.add_argument("--checkpoint", default="best", metavar="best|latest|N",
                        help="which checkpoint: the best evaluation's (default), the latest, or N samples")


def run(args: argparse.Namespace) -> int:
    character_option.check(args.character, args.run_dir)
    from mjxmimic.core.errors import UserError
    from mjxmimic.runs.export import export_run

    fmt = args.format
    if fmt is None:
        fmt = "onnx" if args.out is not None and args.out.suffix == ".onnx" else "npz"
    if args.out is not None and args.out.suffix not in (f".{fmt}",):
        raise UserError(f"--out {args.out}: the file name of a {fmt} export must end in .{fmt}")
    out, pf = export_run(args.run_dir, args.out, fmt, args.checkpoint)
    if args.json:
        print(json.dumps(dict(pf.manifest, file=str(out)), indent=1))
        return 0
    m = pf.manifest
    sizes = " x ".join(str(h) for h in m["policy"]["hidden_sizes"])
    line = (f"{out}: {fmt}, {out.stat().st_size / 1024:.0f} KiB; policy {m['observation']['size']} -> "
            f"{sizes} -> {m['character']['action_size']}, clip {m['clip']['name']}, "
            f"{'best ' if m['training'].get('best') else ''}checkpoint {m['training']['checkpoint']:,} samples")
    ev = m["training"].get("eval")
    if ev and ev.get("nr") is not None:
        line += f", training NR {ev['nr']:.3f}"
    print(line)
    return 0
