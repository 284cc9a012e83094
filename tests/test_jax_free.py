"""The JAX-free side (clips, the motion library, the CPU env and its physics, playback, the
exported policy file and its numpy forward pass) imports and runs without JAX."""

import subprocess
import sys

CODE = """
import sys
import numpy as np
from mjxmimic.core.character import load_character
from mjxmimic.core.config import make_config
from mjxmimic.motion.clip import load_clip_source
from mjxmimic.envs.cpu_env import CpuEnv
import mjxmimic.portable.playback, mjxmimic.portable.policy_file, mjxmimic.portable.policy_numpy
import mjxmimic.portable.push_playback, mjxmimic.portable.composite, mjxmimic.envs.composite, mjxmimic.task.recovery
ch = load_character()
env = CpuEnv(make_config("cpu"), ch, load_clip_source("slow_walk", ch))
env.reset_at(0.2)
s = env.step(np.zeros(ch.action_size), grade_paper=True)
assert np.isfinite(s.obs).all()
bad = sorted(m for m in sys.modules if m.split(".")[0] in ("jax", "jaxlib", "brax", "flax", "optax"))
print(bad)
sys.exit(1 if bad else 0)
"""


def test_cpu_side_never_imports_jax():
    result = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, timeout=300, check=False)
    assert result.returncode == 0, result.stdout + result.stderr


BLAS_CODE = """
import os, sys
for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.pop(name, None)
os.environ["MKL_NUM_THREADS"] = "3"
from mjxmimic import cli
numpy_first = []
limit = cli.one_blas_thread
cli.one_blas_thread = lambda: (numpy_first.append("numpy" in sys.modules), limit())
code = cli.main(["play", "no_such_policy.npz"])
print(code, numpy_first, os.environ["OMP_NUM_THREADS"], os.environ["OPENBLAS_NUM_THREADS"], os.environ["MKL_NUM_THREADS"])
"""


def test_play_limits_blas_to_one_thread_before_numpy_loads():
    """numpy reads the thread counts once, at import: the limit must come first, and a user's
    own setting (MKL's 3 here) stays."""
    result = subprocess.run([sys.executable, "-c", BLAS_CODE], capture_output=True, text=True, timeout=300, check=False)
    assert result.stdout.split() == ["2", "[False]", "1", "1", "3"], result.stdout + result.stderr
