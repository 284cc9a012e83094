"""The commands' persistent compilation cache: where it lives, how it is turned off, and that a
folder it cannot write costs one line, not the run."""

import os
import subprocess
import sys
from pathlib import Path

import jax
import pytest

from mjxmimic.core import compile_cache

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture
def no_cache_env(monkeypatch):
    for name in (compile_cache.ENV, "JAX_COMPILATION_CACHE_DIR", "XDG_CACHE_HOME"):
        monkeypatch.delenv(name, raising=False)
    return monkeypatch


def test_folder_rules(no_cache_env, tmp_path):
    assert compile_cache.cache_dir() == Path.home() / ".cache" / "mjxmimic" / "xla"
    no_cache_env.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert compile_cache.cache_dir() == tmp_path / "mjxmimic" / "xla"
    no_cache_env.setenv(compile_cache.ENV, str(tmp_path / "mine"))
    assert compile_cache.cache_dir() == tmp_path / "mine"
    no_cache_env.setenv(compile_cache.ENV, "off")
    assert compile_cache.cache_dir() is None
    no_cache_env.setenv(compile_cache.ENV, str(tmp_path / "mine"))
    no_cache_env.setenv("JAX_COMPILATION_CACHE_DIR", str(tmp_path / "users"))  # the user's own: JAX reads it
    assert compile_cache.cache_dir() is None


def test_unwritable_folder_is_one_line(no_cache_env, tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    no_cache_env.setenv(compile_cache.ENV, str(blocker / "cache"))
    before = jax.config.jax_compilation_cache_dir
    assert compile_cache.enable() is None
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(blocker / "cache") in err[0] and "compilation cache off" in err[0]
    assert jax.config.jax_compilation_cache_dir == before


def test_a_compiled_program_lands_in_the_folder(tmp_path):
    """In a fresh process (as a command runs): enable(), compile, and the entry is in the folder."""
    folder = tmp_path / "xla"
    code = ("from mjxmimic.core import compile_cache; print(compile_cache.enable()); import jax, jax.numpy as jnp; "
            "jax.config.update('jax_persistent_cache_min_compile_time_secs', 0.0); "
            "jax.jit(lambda x: jnp.sin(x) @ x.T).lower(jnp.ones((8, 8))).compile()")
    env = dict(os.environ, **{compile_cache.ENV: str(folder)})
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=REPO, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == str(folder)
    assert [p.name for p in folder.iterdir() if p.name.endswith("-cache")]
