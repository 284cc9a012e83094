"""Shared fixtures. The real DeepMimic data lives in ../shared/deepmimic beside the checkout;
the env tests use the project's own clips so that nothing skips without it. One compiled env per
session, and JAX's persistent compilation cache (.pytest_cache/jax), keep the fast tier fast."""

import os
from pathlib import Path

import jax
import pytest

from mjxmimic.core import compile_cache

REPO = Path(__file__).resolve().parent.parent
DEEPMIMIC = REPO.parent / "shared" / "deepmimic"

# the commands' own cache (mjxmimic.core.compile_cache), in-process and in subprocesses, is this one,
# set up here as the commands set it up: a test process that wrote entries without their access
# times (no size bound) broke the eviction scan of the commands it started ("Error writing
# persistent compilation cache entry")
os.environ["MJXMIMIC_COMPILE_CACHE"] = str(REPO / ".pytest_cache" / "jax")
compile_cache.enable()
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


@pytest.fixture(scope="session")
def deepmimic_dir() -> Path:
    if not DEEPMIMIC.is_dir():
        pytest.skip("../shared/deepmimic is not present")
    return DEEPMIMIC


@pytest.fixture(scope="session")
def character():
    from mjxmimic.core.character import load_character

    return load_character()


@pytest.fixture(scope="session")
def residual_env(character):
    """The cpu preset with residual targets on the project's slow_walk, MJX-JAX."""
    from mjxmimic.core.config import make_config
    from mjxmimic.envs.mjx_env import ImitationEnv
    from mjxmimic.motion.clip import load_clip_source

    config = make_config("cpu", {"env.action_mode": "residual", "physics.backend": "jax"})
    return ImitationEnv(config, character, [load_clip_source("slow_walk", character)])


@pytest.fixture(scope="session")
def env_fns(residual_env):
    """residual_env's functions, each compiled once per session and shared by every test."""
    from types import SimpleNamespace

    env = residual_env
    return SimpleNamespace(
        reset_at=jax.jit(env.reset_at),
        transition=jax.jit(env.transition),
        evaluate=jax.jit(lambda s, a: env.transition(s, a, evaluation=True)),
        step=jax.jit(env.step),
    )


@pytest.fixture(scope="session")
def headless_video():
    """Skips a test that writes a video where the render extra or headless OpenGL is missing."""
    pytest.importorskip("imageio_ffmpeg", reason="the render extra is not installed")
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable.render import setup_gl

    try:
        return setup_gl()
    except UserError as err:
        pytest.skip(f"no headless OpenGL: {err}")
