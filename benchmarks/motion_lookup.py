"""Reference-pose lookup speed for a library of 1 clip and of 100 clips (jitted, vmapped, CPU).

The lookup is constant time per sample (a per-clip time grid), so both should take about as long.
The 100-clip library repeats the project's clips (slow_walk, squat, wave) with equal weights.

    JAX_PLATFORMS=cpu python benchmarks/motion_lookup.py --batch 4096 --repeats 50
"""

from __future__ import annotations

import argparse
import time
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from mjxmimic.core.character import load_character
from mjxmimic.motion import library as motion
from mjxmimic.motion.clip import load_clip_source

PROJECT_CLIPS = ("slow_walk", "squat", "wave")


def time_sampling(lib: motion.MotionLib, batch: int, repeats: int,
                  sample: Callable[..., Any] = motion.sample) -> float:
    """Median seconds of one jitted, vmapped call: draw `batch` clips by weight, sample each."""
    jlib = jax.tree.map(jnp.asarray, lib)

    @jax.jit
    def step(key: jax.Array) -> tuple[jax.Array, jax.Array]:
        ku, kt = jax.random.split(key)
        clips = jax.vmap(lambda u: motion.draw_clip(jlib, u, jnp))(jax.random.uniform(ku, (batch,)))
        t = jax.random.uniform(kt, (batch,), maxval=10.0)
        return jax.vmap(lambda c, s: sample(jlib, c, s, jnp))(clips, t)

    key = jax.random.key(0)
    jax.block_until_ready(step(key))  # compile
    times = []
    for _ in range(repeats):
        key, sub = jax.random.split(key)
        start = time.perf_counter()
        jax.block_until_ready(step(sub))
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=4096, help="samples per call")
    parser.add_argument("--repeats", type=int, default=50, help="timed calls (the median is printed)")
    args = parser.parse_args()
    character = load_character()
    clips = [load_clip_source(name, character) for name in PROJECT_CLIPS]
    print(f"device {jax.devices()[0].platform}, batch {args.batch}, median of {args.repeats} calls")
    for count in (1, 100):
        lib = motion.build_motion_lib([clips[i % len(clips)] for i in range(count)], character)
        seconds = time_sampling(lib, args.batch, args.repeats)
        print(f"{count:4d} clips, {len(lib.times):6d} frames: {seconds * 1e3:8.3f} ms per call, "
              f"{args.batch / seconds / 1e6:7.2f} M samples/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
