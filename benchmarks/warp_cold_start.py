"""What a machine's first run pays for MuJoCo Warp's kernels, and whether loading them ahead helps.

Warp compiles each kernel module the first time it is launched on a machine and keeps the result
in its kernel cache (~/.cache/warp); later runs load it from there. This script starts from an
empty cache (a fresh temporary folder), builds the `gpu` preset's env and trainer, optionally
loads every module known at that point in parallel (`warp.force_load(max_workers=16)`, mode
"preload"), then times the first training iteration and lists the modules loaded during it.

    python benchmarks/warp_cold_start.py serial; python benchmarks/warp_cold_start.py preload
"""

import os
import sys
import tempfile
import time

T0 = time.time()
mode = sys.argv[1] if len(sys.argv) > 1 else "serial"
import warp as wp  # noqa: E402

wp.config.kernel_cache_dir = tempfile.mkdtemp(prefix="warp_cache_")
import jax  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from warp._src import context  # noqa: E402

from mjxmimic.core import config as config_lib  # noqa: E402
from mjxmimic.envs.mjx_env import make_env  # noqa: E402
from mjxmimic.learn.ppo import make_trainer  # noqa: E402

config = config_lib.make_config("gpu", {"clip.name": "walk"})
env = make_env(config)
trainer = make_trainer(env, config)
print(f"[{mode}] built at {time.time() - T0:.1f}s; user modules {len(context.user_modules)}", flush=True)
if mode == "preload":
    t = time.time()
    wp.force_load(device="cuda:0", max_workers=16)
    print(f"[{mode}] force_load all {len(context.user_modules)} modules: {time.time() - t:.1f}s", flush=True)
before = {name for name, m in context.user_modules.items() if m.execs}
step = trainer.compile_train_step()
ts = trainer.init(0)
t = time.time()
jax.block_until_ready(step(ts))
print(f"[{mode}] first iteration {time.time() - t:.1f}s", flush=True)
after = {name for name, m in context.user_modules.items() if m.execs}
print(f"[{mode}] modules now {len(context.user_modules)}, loaded {len(after)}, loaded during the step "
      f"{len(after - before)}: {sorted(after - before)}", flush=True)
print(f"[{mode}] total {time.time() - T0:.1f}s", flush=True)
