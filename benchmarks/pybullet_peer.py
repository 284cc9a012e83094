"""Peer benchmark (issue 5, part 2): environment samples/s of the PyBullet port of DeepMimic on the CPU.

The peer is `pybullet_envs.deep_mimic` from the PyPI package `pybullet` (not a dependency of this
project; install it with `pip install pybullet`). It is run with its own settings, unchanged:
physics at 1/240 s, 8 physics steps per 30 Hz action, Bullet's C++ stable PD
(`STABLE_PD_CONTROL`) re-applied every physics step, 10 solver iterations, the humanoid
`humanoid/humanoid.urdf` at `globalScaling=0.25`, random state initialisation, the per-step
imitation reward and contact-based early termination.

A sample is one policy step (one 30 Hz action of one environment). Each step does exactly what the
package's gym wrapper `HumanoidDeepBulletEnv.step` (pybullet_envs/deep_mimic/gym_env/deep_mimic_env.py)
does with the internal `PyBulletDeepMimicEnv`: `calc_reward`, `set_action`, 8 x `update(1/240)`,
`record_state` plus its observation rescaling, `is_episode_end`; on termination the env is reset
(`reset` + `record_state`), as a rollout worker would. Actions are random, uniform within the env's
own bounds (`build_action_bound_min/max`). There is no policy network and no learning: this is an
environment-step rate, an upper bound for what a CPU learner could consume from one process.

The gym wrapper class itself is not instantiated: its module imports `gym` (whose registry API
`pybullet_envs/__init__.py` needs, gym < 0.24) and `pybullet_utils.logger` (which needs `mpi4py`).
To run with `pybullet` alone this script bypasses `pybullet_envs/__init__.py` (it only registers gym
ids) and drives the internal env with the wrapper's step sequence above.

The machine may be shared: before each timed block the script waits (up to --max-wait-quiet s) for
the CPUs to be idle, and it records the load average and, per timed block, the share of one core
each worker actually got (process CPU time / wall time), the share of all CPU time that was idle or
stolen (/proc/stat) and an estimate of the cores kept busy by other users.

Measured: 1 process, and 2 processes in parallel (one env each, total samples/s over the common
wall-clock window). Each configuration: warm-up, then `--repeats` timed blocks of `--steps` steps
per process; the median block is reported.

    python benchmarks/pybullet_peer.py --clips walk backflip --steps 2000 --repeats 3 \
        --out benchmarks/results/pybullet_peer_cpu.json
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import importlib.util
import json
import math
import multiprocessing as mp
import os
import platform
import statistics
import sys
import time
import types

ORIGINAL_DEEPMIMIC_WORKERS = 16


def _import_peer():
    """Import the peer's internal env without running pybullet_envs/__init__.py (gym registration)."""
    if "pybullet_envs" not in sys.modules:
        spec = importlib.util.find_spec("pybullet_envs")
        if spec is None or spec.submodule_search_locations is None:
            raise SystemExit("pybullet is not installed: pip install pybullet")
        pkg = types.ModuleType("pybullet_envs")
        pkg.__path__ = list(spec.submodule_search_locations)
        sys.modules["pybullet_envs"] = pkg
    import pybullet
    import pybullet_data
    from pybullet_envs.deep_mimic.env import pybullet_deep_mimic_env as pdme
    from pybullet_utils.arg_parser import ArgParser

    return pybullet, pybullet_data, pdme, ArgParser


@contextlib.contextmanager
def _quiet():
    """Silence the peer's construction chatter (Python prints and Bullet's C-level warnings)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


class PeerEnv:
    """The peer env, stepped exactly as pybullet's HumanoidDeepBulletEnv.step does (see module doc)."""

    AGENT = -1  # the gym wrapper's agent id (unused by the single-agent env)

    def __init__(self, clip: str, seed: int):
        import random

        import numpy as np

        random.seed(seed)  # the env's random state initialisation uses `random`
        self.rng = np.random.default_rng(seed)
        _, pybullet_data, pdme, ArgParser = _import_peer()
        self.time_step = 1.0 / 240  # HumanoidDeepBulletEnv default time_step
        self.policy_step = 1.0 / 30  # HumanoidDeepBulletEnv: policy_query_30 = True
        self.substeps = int(self.policy_step / self.time_step)  # the wrapper's _num_env_steps
        self.arg_file = f"run_humanoid3d_{clip}_args.txt"  # as the gym Walk/Backflip classes
        parser = ArgParser()
        if not parser.load_file(os.path.join(pybullet_data.getDataPath(), "args", self.arg_file)):
            raise SystemExit(f"no arg file {self.arg_file} in pybullet_data/args")
        with _quiet():
            self.env = pdme.PyBulletDeepMimicEnv(
                parser,
                False,  # enable_draw: DIRECT mode, no GUI
                time_step=self.time_step,
                init_strategy=pdme.InitializationStrategy.RANDOM,
            )
        self.low = np.asarray(self.env.build_action_bound_min(self.AGENT), dtype=np.float64)
        self.high = np.asarray(self.env.build_action_bound_max(self.AGENT), dtype=np.float64)
        self.state_mean = -self.env.build_state_offset(self.AGENT)
        self.state_std = 1.0 / self.env.build_state_scale(self.AGENT)
        self.episodes_ended = 0
        self.reset()

    def physics_params(self) -> dict:
        p = self.env._pybullet_client.getPhysicsEngineParameters()
        return {k: p[k] for k in ("fixedTimeStep", "numSubSteps", "numSolverIterations")}

    def _obs(self):
        state = self.env.record_state(self.AGENT)
        return (state - self.state_mean) / (self.state_std + 1e-8)

    def reset(self):
        self.env.reset()
        return self._obs()

    def sample_action(self):
        return self.rng.uniform(self.low, self.high)

    def step(self, action):
        reward = self.env.calc_reward(self.AGENT)
        self.env.set_action(self.AGENT, action)
        for _ in range(self.substeps):
            self.env.update(self.time_step)
        obs = self._obs()
        done = self.env.is_episode_end()
        if done:
            self.episodes_ended += 1
            obs = self.reset()
        return obs, reward, done


def cpu_times() -> list[int]:
    """Aggregate `cpu` line of /proc/stat: user nice system idle iowait irq softirq steal ..."""
    try:
        with open("/proc/stat") as f:
            return [int(x) for x in f.readline().split()[1:]]
    except OSError:
        return []


def cpu_share(before: list[int], after: list[int]) -> dict:
    """Share of all CPU time in a window that was idle or stolen by the hypervisor (/proc/stat)."""
    if not before or not after:
        return {}
    d = [b - a for a, b in zip(before, after)]
    total = sum(d[:8]) or 1
    return {"idle": round((d[3] + d[4]) / total, 4), "steal": round(d[7] / total, 4) if len(d) > 7 else None}


def wait_quiet(max_wait_s: float, min_idle: float = 0.9) -> dict:
    """On a shared machine: wait (up to max_wait_s) until >= min_idle of all CPU time is idle."""
    t_start = time.monotonic()
    while True:
        c0 = cpu_times()
        time.sleep(1.0)
        share = cpu_share(c0, cpu_times())
        idle = share.get("idle", 1.0)
        waited = time.monotonic() - t_start
        if idle >= min_idle or waited >= max_wait_s:
            return {"idle_before": idle, "waited_s": round(waited, 1), "quiet": idle >= min_idle}
        time.sleep(4.0)


def _worker(rank, clip, seed, warmup, steps, repeats, max_wait_s, barrier, queue):
    env = PeerEnv(clip, seed)
    for _ in range(warmup):
        env.step(env.sample_action())
    queue.put(("info", env.physics_params(), env.substeps, env.arg_file))
    for _ in range(repeats):
        ended0 = env.episodes_ended
        quiet = {}
        barrier.wait()  # everyone warmed up / done with the previous block (workers sleep here)
        if rank == 0 and max_wait_s > 0:
            quiet = wait_quiet(max_wait_s)
        barrier.wait()
        c0 = cpu_times()
        p0 = time.process_time()
        t0 = time.monotonic()  # CLOCK_MONOTONIC: one system-wide clock, comparable across processes
        for _ in range(steps):
            env.step(env.sample_action())
        t1 = time.monotonic()
        util = (time.process_time() - p0) / (t1 - t0)  # share of one core this worker actually got
        queue.put(("block", t0, t1, env.episodes_ended - ended0, util, cpu_share(c0, cpu_times()), quiet))


def measure(
    clip: str, nproc: int, warmup: int, steps: int, repeats: int, seed: int, max_wait_s: float
) -> dict:
    ctx = mp.get_context("fork")
    barrier = ctx.Barrier(nproc)
    queue = ctx.Queue()
    procs = [
        ctx.Process(
            target=_worker,
            args=(i, clip, seed + 1000 * i, warmup, steps, repeats, max_wait_s, barrier, queue),
        )
        for i in range(nproc)
    ]
    for p in procs:
        p.start()
    info, blocks = None, []
    for _ in range(nproc * (repeats + 1)):
        msg = queue.get(timeout=3600 + repeats * max_wait_s)
        if msg[0] == "info":
            info = msg[1:]
        else:
            blocks.append(msg[1:])
    for p in procs:
        p.join()
        if p.exitcode != 0:
            raise SystemExit(f"worker failed with exit code {p.exitcode}")
    blocks.sort(key=lambda b: b[0])  # by start time; the barriers keep each repeat's blocks adjacent
    totals, per_proc, utils, ended, shares, quiets = [], [], [], [], [], []
    for r in range(repeats):
        group = blocks[r * nproc : (r + 1) * nproc]
        wall = max(b[1] for b in group) - min(b[0] for b in group)
        totals.append(nproc * steps / wall)
        per_proc.append([steps / (b[1] - b[0]) for b in group])
        utils.append([round(b[3], 3) for b in group])
        ended.append(sum(b[2] for b in group))
        share = dict(group[0][4])
        if share:  # busy cores not explained by our own workers: other users of the machine
            busy = (os.cpu_count() or 1) * (1.0 - share["idle"] - (share["steal"] or 0.0))
            share["other_busy_cores_est"] = round(max(0.0, busy - sum(b[3] for b in group)), 2)
        shares.append(share)
        quiets.append(next((b[5] for b in group if b[5]), {}))
    return {
        "processes": nproc,
        "steps_per_process": steps,
        "samples_per_s_median": statistics.median(totals),
        "samples_per_s_repeats": totals,
        "per_process_samples_per_s": per_proc,
        "per_process_cpu_util": utils,
        "episodes_ended_per_repeat": ended,
        "mean_episode_len_steps": (nproc * steps * repeats) / max(1, sum(ended)),
        "machine_cpu_share_per_repeat": shares,
        "wait_quiet_per_repeat": quiets,
        "loadavg_after": os.getloadavg(),
        "_info": info,
    }


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clips", nargs="+", default=["walk", "backflip"])
    ap.add_argument("--steps", type=int, default=2000, help="timed policy steps per process per repeat")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=100, help="untimed policy steps per process")
    ap.add_argument("--procs", type=int, nargs="+", default=[1, 2], help="process counts to measure")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--max-wait-quiet",
        type=float,
        default=600.0,
        help="shared machine: before each timed block wait up to this many seconds for the "
        "CPUs to be >= 90%% idle (0: do not wait)",
    )
    ap.add_argument("--out", default="benchmarks/results/pybullet_peer_cpu.json")
    args = ap.parse_args(argv)

    pybullet, _, _, _ = _import_peer()
    from importlib.metadata import PackageNotFoundError, version

    try:
        pb_version = version("pybullet")
    except PackageNotFoundError:
        pb_version = "unknown"
    import numpy as np

    result = {
        "benchmark": "peer: PyBullet port of DeepMimic (pybullet_envs.deep_mimic), environment samples/s",
        "note": "random actions, no policy network, no learning: an environment-step rate",
        "device": cpu_model(),
        "cores": os.cpu_count(),
        "cores_usable": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "pybullet": pb_version,
        "pybullet_api_version": pybullet.getAPIVersion(),
        "command": "python " + " ".join([os.path.relpath(sys.argv[0])] + sys.argv[1:]),
        "steps": args.steps,
        "repeats": args.repeats,
        "warmup": args.warmup,
        "loadavg_before": os.getloadavg(),
        "clips": {},
    }
    for clip in args.clips:
        entry = {}
        for nproc in args.procs:
            print(f"[{clip}] {nproc} process(es): {args.repeats} x {args.steps} steps ...", flush=True)
            res = measure(clip, nproc, args.warmup, args.steps, args.repeats, args.seed, args.max_wait_quiet)
            phys, substeps, arg_file = res.pop("_info")
            entry.setdefault("arg_file", arg_file)
            entry.setdefault(
                "physics",
                {
                    **phys,
                    "physics_hz": round(1.0 / phys["fixedTimeStep"], 3),
                    "substeps_per_action": substeps,
                    "action_hz": 30,
                },
            )
            entry[f"procs_{nproc}"] = res
            print(
                f"    median {res['samples_per_s_median']:.1f} samples/s "
                f"(repeats {', '.join(f'{x:.1f}' for x in res['samples_per_s_repeats'])}; "
                f"loadavg {res['loadavg_after'][0]:.2f}; worker cpu util {res['per_process_cpu_util']})",
                flush=True,
            )
        if "procs_1" in entry:
            entry["estimate_16_workers_linear"] = {
                "samples_per_s": ORIGINAL_DEEPMIMIC_WORKERS * entry["procs_1"]["samples_per_s_median"],
                "label": "ESTIMATE, not measured: 16 x the 1-process median (DeepMimic used 16 CPU workers)",
            }
        result["clips"][clip] = entry
    result["loadavg_after"] = os.getloadavg()
    first = next(iter(result["clips"].values()))["physics"]
    result["physics_hz"] = first["physics_hz"]
    result["substeps_per_action"] = first["substeps_per_action"]

    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(result, f, indent=2)
            f.write("\n")

    print()
    print(
        f"device: {result['device']} ({result['cores']} cores), pybullet {pb_version}, "
        f"python {result['python']}, {result['date']}"
    )
    print(
        f"physics {first['physics_hz']:g} Hz, {first['substeps_per_action']} substeps per 30 Hz action, "
        f"loadavg before/after {result['loadavg_before'][0]:.2f}/{result['loadavg_after'][0]:.2f}"
    )
    cols = [f"{n} proc" for n in args.procs]
    print(f"{'clip':<10}" + "".join(f"{c:>12}" for c in cols) + f"{'16 (est.)':>12}  samples/s")
    for clip, entry in result["clips"].items():
        row = "".join(f"{entry[f'procs_{n}']['samples_per_s_median']:>12.1f}" for n in args.procs)
        est = entry.get("estimate_16_workers_linear", {}).get("samples_per_s", math.nan)
        print(f"{clip:<10}{row}{est:>12.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
