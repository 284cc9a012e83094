"""What the compilation cache (mjxmimic.core.compile_cache) saves at a run's start: the same
`mjxmimic train` twice against one fresh, empty cache folder; the first compiles and fills it, the
second loads; a third with another learning rate and sample budget (the train step takes them as
arguments, so it loads too). Each run's "first iteration done ... N s since the start" line and
its wall-clock.

    python benchmarks/compile_cache.py --out benchmarks/results/compile_cache_cpu.json [-- TRAIN ARGS]

TRAIN ARGS default to the README's main job, shortened: `--preset cpu --set run.total_samples=4096`.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mjxmimic.core import compile_cache  # noqa: E402
from mjxmimic.ops.bench import environment_info  # noqa: E402


def train_once(args: list[str], cache: Path, out: Path) -> dict:
    env = dict(os.environ, **{compile_cache.ENV: str(cache)})
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    start = time.time()
    done = subprocess.run([sys.executable, "-m", "mjxmimic.cli", "train", "--out", str(out), *args], env=env,
                          cwd=REPO, capture_output=True, text=True)
    wall = time.time() - start
    if done.returncode != 0:
        sys.exit(f"compile_cache: mjxmimic train failed:\n{done.stderr[-2000:]}")
    first = re.search(r"; (\d+) s since the start", done.stderr)
    return {"first_iteration_done_s": int(first.group(1)) if first else None, "wall_s": round(wall, 1)}


OTHER_SCHEDULE = ["--set", "ppo.learning_rate=0.0001", "--set", "run.total_samples=8192"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("train_args", nargs="*", default=["--preset", "cpu", "--set", "run.total_samples=4096"])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        cache = Path(tmp) / "xla"
        runs = [train_once(args.train_args, cache, Path(tmp) / f"run{i}") for i in (1, 2)]
        other = [*args.train_args, *OTHER_SCHEDULE]
        runs.append(train_once(other, cache, Path(tmp) / "run3"))
        entries = sorted(p.name for p in cache.iterdir() if p.name.endswith("-cache"))
    result = {"train_args": args.train_args, "cold": runs[0], "warm": runs[1],
              "warm_other_schedule": dict(runs[2], extra_args=OTHER_SCHEDULE), "cache_entries": len(entries),
              **environment_info()}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
