"""JAX's persistent compilation cache for the commands that compile (train, eval, export, bench,
and the trials of a sweep, which are `mjxmimic train` processes).

Compilation is most of a short run's start; with the cache, a run whose programs have the same
shapes and settings as an earlier one's loads them from disk instead. The cache lives in
MJXMIMIC_COMPILE_CACHE (a folder), by default ~/.cache/mjxmimic/xla (under XDG_CACHE_HOME when
set); MJXMIMIC_COMPILE_CACHE=off turns it off, and a JAX_COMPILATION_CACHE_DIR of the user's own
is left to JAX. Least recently used entries go beyond MAX_BYTES (where the `filelock` package,
which JAX's eviction needs, is installed; else the folder is not bounded).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ENV = "MJXMIMIC_COMPILE_CACHE"
OFF = ("off", "0", "none", "false")
MAX_BYTES = 4 << 30


def default_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "mjxmimic" / "xla"


def cache_dir() -> Path | None:
    """The folder this process would cache in (None when off or left to JAX)."""
    value = os.environ.get(ENV, "").strip()
    if value.lower() in OFF or os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        return None
    return Path(value).expanduser() if value else default_dir()


def enable() -> Path | None:
    """Point JAX's persistent cache at `cache_dir()`; a folder that cannot be written gets one
    line on stderr and the run goes on without the cache."""
    path = cache_dir()
    if path is None:
        return None
    try:
        path.mkdir(parents=True, exist_ok=True)
        problem = "" if os.access(path, os.W_OK) else "not writable"
    except OSError as err:
        problem = err.strerror or str(err)
    if problem:
        print(f"mjxmimic: compilation cache off: {path}: {problem} (set {ENV} to another folder, or to off)",
              file=sys.stderr)
        return None
    import importlib.util

    import jax

    jax.config.update("jax_compilation_cache_dir", str(path))
    if importlib.util.find_spec("filelock") is not None:
        jax.config.update("jax_compilation_cache_max_size", MAX_BYTES)
    return path
