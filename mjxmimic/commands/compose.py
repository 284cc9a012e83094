"""`mjxmimic compose`: bundle independently trained experts (run folders or exported policies)
into one composite file; `mjxmimic play` runs it with its gate (mjxmimic.portable.composite)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("experts", type=Path, nargs="+", metavar="RUN_OR_POLICY",
                        help="the experts: run folders (their best checkpoint) or exported .npz files")
    parser.add_argument("--out", type=Path, required=True, metavar="FILE", help="the composite file (.npz)")
    parser.add_argument("--temperature", type=float, default=None,
                        help="the gate's softmax temperature over the experts' values (default 0.3)")


def run(args: argparse.Namespace) -> int:
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable import composite
    from mjxmimic.runs.folder import load_policy_file

    if args.out.suffix != ".npz":
        raise UserError(f"--out {args.out}: a composite file's name must end in .npz")
    experts = [load_policy_file(p, export_if_missing=True) for p in args.experts]
    temperature = composite.TEMPERATURE if args.temperature is None else args.temperature
    out = composite.write(composite.compose(experts, temperature), args.out)
    print(f"{out}: {len(experts)} experts ({', '.join(pf.clip().name for pf in experts)}), "
          f"temperature {temperature}")
    return 0
