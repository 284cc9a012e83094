"""What a command does before its first use of JAX and MJX, wherever that comes (train, eval,
export and bench at once; render and compose when handed a run folder without its policy
file): mujoco.mjx imported without its notice about a missing warp package, and JAX's
compilation cache on (mjxmimic.core.compile_cache)."""

from __future__ import annotations

import contextlib
import importlib
import io
import sys

from mjxmimic.core import compile_cache

WARP_NOTICES = ("Failed to import warp:", "Failed to import mujoco_warp:")


def import_mjx_quietly() -> None:
    """mujoco.mjx prints "Failed to import warp: ..." on stdout whenever the optional warp package
    is missing (every CPU machine): drop those lines; pass anything else it prints to stderr, so
    that `--json` output stays JSON."""
    if "mujoco.mjx" in sys.modules:
        return
    captured = io.StringIO()
    with contextlib.redirect_stdout(captured):
        importlib.import_module("mujoco.mjx")
    for line in captured.getvalue().splitlines():
        if not line.startswith(WARP_NOTICES):
            print(line, file=sys.stderr)


def prepare() -> None:
    import_mjx_quietly()
    compile_cache.enable()
