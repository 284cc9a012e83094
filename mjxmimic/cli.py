"""`mjxmimic` command line: one subcommand per module, imported only when it runs.

Each command module defines `add_arguments(parser)` and `run(args) -> int`. Heavy imports (JAX)
happen inside `run`, so `mjxmimic play` stays JAX-free.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from mjxmimic.core import jax_setup
from mjxmimic.core.errors import UserError

COMMANDS = {
    "train": ("mjxmimic.commands.train", "train a policy on a clip"),
    "eval": ("mjxmimic.commands.evaluate", "normalised return (NR) of a run's policy"),
    "clips": ("mjxmimic.commands.clips", "list, inspect and render motion clips"),
    "export": ("mjxmimic.commands.export", "write a run's policy to one portable file"),
    "play": ("mjxmimic.commands.play", "play an exported policy in MuJoCo on the CPU (no JAX)"),
    "compose": ("mjxmimic.commands.compose", "bundle trained experts into one composite policy"),
    "render": ("mjxmimic.commands.render", "render a policy to a video"),
    "bench": ("mjxmimic.commands.bench", "throughput benchmarks"),
    "sweep": ("mjxmimic.commands.sweep", "run a grid of training runs and report"),
}
USES_MJX = ("train", "eval", "export", "bench")  # the others stay JAX-free where they can
PLAYS_ON_CPU = ("play", "render")  # MuJoCo C and the numpy policy, one observation at a time


def one_blas_thread() -> None:
    """One BLAS thread per process unless the user chose otherwise, set before numpy is first
    imported (it reads these then). One observation's pass through the policy is too small to
    split, and beside other busy processes (the push test's workers, a grade beside training) a
    pool of one thread per core only makes each step wait (benchmarks/RESULTS.md)."""
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, "1")


def build_parser() -> argparse.ArgumentParser:
    from mjxmimic import __version__

    parser = argparse.ArgumentParser(prog="mjxmimic", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"mjxmimic {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (module_name, help_text) in COMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as err:
            if err.name != module_name:
                raise
            continue
        module.add_arguments(sub.add_parser(name, help=help_text, description=help_text))
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command in USES_MJX:
        jax_setup.prepare()
    elif args.command in PLAYS_ON_CPU:
        one_blas_thread()
    module = importlib.import_module(COMMANDS[args.command][0])
    try:
        return int(module.run(args) or 0)
    except UserError as err:
        print(f"mjxmimic {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"mjxmimic {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
