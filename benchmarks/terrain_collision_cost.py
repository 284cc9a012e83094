"""Terrain collision cost on MJX impl='jax' (CPU): the humanoid's physics step on the flat floor, on the
box course (dense gaps, one lane) and on the same course as a 5 cm height field; 16 envs, 4 substeps.

    PYTHONPATH=. python benchmarks/terrain_collision_cost.py
"""
import time

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

from mjxmimic.core import terrain as T
from mjxmimic.core.character import load_character
from mjxmimic.core.scene import build_scene

ch = load_character()
n = 16

def bench(m, label):
    mx = mjx.put_model(m, impl="jax")
    d = mujoco.MjData(m); d.qpos[2] += 0.02
    dx = jax.vmap(lambda i: mjx.put_data(m, d, impl="jax"))(jnp.arange(n))
    f = jax.jit(jax.vmap(lambda x: jax.lax.fori_loop(0, 4, lambda i, y: mjx.step(mx, y), x)))
    t0 = time.time(); out = jax.block_until_ready(f(dx)); c = time.time() - t0
    t0 = time.time()
    for _ in range(5):
        out = f(out)
    jax.block_until_ready(out)
    dt = (time.time() - t0) / 5
    print(f"{label:28s} ngeom {m.ngeom:3d} compile {c:5.1f} s  4 substeps x {n} envs {dt*1e3:7.1f} ms  root z {float(out.qpos[0,2]):.3f}", flush=True)

bench(build_scene(ch, 120, 4, 4).model, "flat")
bench(build_scene(ch, 120, 4, 4, T.generate("gaps", lanes=1, length=12)).model, "boxes gaps 1 lane")
# height field: the same gaps course sampled at 5 cm
t = T.generate("gaps", lanes=1, length=12)
xs = np.arange(-2.0, 15.0, 0.05); ys = np.arange(-1.5, 1.5001, 0.05)
gx, gy = np.meshgrid(xs, ys)
h = T.height(t.boxes, t.depth, np.stack([gx, gy], -1), np) + t.depth
spec = mujoco.MjSpec.from_file(str(ch.xml_path))
hf = spec.add_hfield(); hf.name = "course"; hf.nrow, hf.ncol = h.shape
hf.size = [(xs[-1]-xs[0])/2, (ys[-1]-ys[0])/2, float(h.max()), 0.1]
hf.userdata = list((h / h.max()).ravel())
g = spec.worldbody.add_geom(); g.type = mujoco.mjtGeom.mjGEOM_HFIELD; g.hfieldname = "course"
g.pos = [(xs[-1]+xs[0])/2, 0, -t.depth]; g.contype, g.conaffinity = 0, 1
m = spec.compile(); m.opt.timestep = 1/120
bench(m, "hfield gaps 1 lane (5 cm)")
