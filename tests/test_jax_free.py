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
