"""`mjxmimic compose RUN_OR_POLICY ... --out composite.npz [--temperature 0.3]`: a composite
policy of independently trained experts (DeepMimic section 7; mjxmimic.portable.composite).

Each argument is an exported policy file (with its value network: files exported before it was
carried must be exported again) or a run folder (its policy.npz, else its best checkpoint exported
in memory, which imports JAX). The experts must share the character, the observation layout and
the control settings, and at least one must be on a looping clip; the file holds every expert's
policy, value network, normaliser and clip. Play it with `mjxmimic play composite.npz`, render it
with `mjxmimic render composite.npz --push FORCE@TIME`, measure its recovery rate with
`mjxmimic eval composite.npz --knockdowns 50` (MJX) or `mjxmimic play composite.npz --knockdowns 50`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from mjxmimic.commands import arg_types


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("experts", type=arg_types.path, nargs="+", metavar="RUN_OR_POLICY",
                        help="exported policy files (.npz) or run folders, one per expert")
    parser.add_argument("--out", type=arg_types.path, required=True, metavar="FILE.npz", help="the composite file to write")
    parser.add_argument("--temperature", type=float, default=0.3,
                        help="the gate's softmax temperature over the experts' values (default 0.3; 0: arg max)")
    parser.add_argument("--json", action="store_true", help="print the composite's manifest summary as JSON")


def run(args: argparse.Namespace) -> int:
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable import composite
    from mjxmimic.runs.folder import load_policy_file

    if args.out.suffix != ".npz":
        raise UserError(f"--out {args.out}: a composite file name must end in .npz")
    experts = []
    for source in args.experts:
        pf = load_policy_file(source, export_if_missing=True)
        pf.path = Path(source) if pf.path is None else pf.path
        experts.append(pf)
    c = composite.compose(experts, args.temperature)
    composite.write(c, args.out)
    rows = [{k: e[k] for k in ("name", "clip", "loop", "duration_s", "nr", "source")} for e in c.manifest["experts"]]
    if args.json:
        print(json.dumps({"file": str(args.out), "temperature": c.temperature, "experts": rows}, indent=1))
        return 0
    print(f"{args.out}: {len(rows)} experts, gate temperature {c.temperature:g}, "
          f"{args.out.stat().st_size / 1024:.0f} KiB")
    for r in rows:
        nr = "-" if r["nr"] is None else f"{r['nr']:.3f}"
        print(f"  {r['name']:<20} {'looping' if r['loop'] else 'one-shot':<9} {r['duration_s']:5.2f} s  "
              f"own NR {nr:>6}  {r['source']}")
    return 0
