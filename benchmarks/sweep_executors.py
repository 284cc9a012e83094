"""What a sweep executor costs per run: the same sweep through the local runner and through Ray Tune.

    python benchmarks/sweep_executors.py [--runs 2 8] [--cpu-preset] [--out FILE]   (--runs alone: none)

A stand-in training that exits at once (`python -c pass`, so each run ends "stopped") isolates the
executor: local runs one after another; Ray once with one trial at a time (2 CPUs per trial on a
2-core machine, as local) and once with a trial per CPU; each timing includes starting and
stopping the local Ray cluster. --cpu-preset adds a 2-run sweep of real `mjxmimic train` runs
(the cpu preset, the tests' tiny budget: slow_walk and squat) the same three ways.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mjxmimic.ops import sweep
from mjxmimic.ops.sweep.executors import ray_executor

TINY = {"run.total_samples": 1024, "ppo.num_envs": 8, "ppo.unroll_length": 4, "ppo.num_minibatches": 2,
        "run.eval_episodes": 2, "env.episode_seconds": 1, "env.physics_hz": 30}


def timed_sweep(folder: Path, fields: dict, executor: object, train: list[str] | None) -> tuple[float, dict]:
    path = folder / "spec.json"
    path.write_text(json.dumps({**fields, "out": str(folder / "out")}))
    spec = sweep.load_spec(path)
    t0 = time.perf_counter()
    results = sweep.Runner(spec, gpus=[], train_command=train, echo=lambda s: None, executor=executor).run()
    return time.perf_counter() - t0, results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, nargs="*", default=[2, 8])
    parser.add_argument("--cpu-preset", action="store_true", help="also a 2-run sweep of real cpu-preset training")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    import ray

    rows = []
    instant = [sys.executable, "-c", "pass"]
    cases = [("local", lambda out, spec: None, instant)]
    cases += [(f"ray, {c} CPU per trial", lambda out, spec, c=c: ray_executor(out, spec, cpus_per_trial=c), instant)
              for c in (os.cpu_count(), 1)]
    for n in args.runs:
        for name, make, train in cases:
            with tempfile.TemporaryDirectory() as tmp:
                fields = {"preset": "cpu", "clip": "squat", "seeds": list(range(n))}
                seconds, results = timed_sweep(Path(tmp), fields, make(Path(tmp) / "out", {}), train)
            rows.append({"sweep": f"{n} instant runs", "executor": name, "seconds": round(seconds, 2),
                         "per_run_s": round(seconds / n, 2), "statuses": sorted(set(results.values()))})
            print(json.dumps(rows[-1]), flush=True)
    if args.cpu_preset:
        for name, make, _ in cases:
            with tempfile.TemporaryDirectory() as tmp:
                fields = {"preset": "cpu", "clips": ["slow_walk", "squat"], "set": TINY}
                seconds, results = timed_sweep(Path(tmp), fields, make(Path(tmp) / "out", {}), None)
            rows.append({"sweep": "2 cpu-preset runs (tiny budget)", "executor": name, "seconds": round(seconds, 2),
                         "per_run_s": round(seconds / 2, 2), "statuses": sorted(set(results.values()))})
            print(json.dumps(rows[-1]), flush=True)
    if args.out:
        info = {"date": time.strftime("%Y-%m-%d"), "python": sys.version.split()[0], "ray": ray.__version__,
                "cpus": os.cpu_count()}
        args.out.write_text(json.dumps({"info": info, "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
