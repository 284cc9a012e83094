"""Samples/s of trainings that shared one GPU, from their metrics.jsonl (issue 19).

    python benchmarks/gpu_sharing.py [--label NAME] RUN@FROM-TO [RUN@FROM-TO ...]

For each run folder, the median of its per-iteration samples/s over the iterations logged
between FROM and TO seconds of its own wall-clock (the `wall` column: a window in which the
runs named together were all training at once), and the sum over the runs: the aggregate
throughput of the GPU, to compare with one run alone (a single RUN@FROM-TO window of a run
that trained by itself). Prints one JSON object.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path


def window_rate(run_dir: Path, start: float, end: float) -> dict:
    rows = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines() if line.strip()]
    rates = [r["samples_per_s"] for r in rows if "samples_per_s" in r and start <= r["wall"] <= end]
    if not rates:
        raise SystemExit(f"gpu_sharing: {run_dir}: no iterations logged between {start:g} and {end:g} s")
    return {"run": run_dir.name, "from_s": start, "to_s": end, "iterations": len(rates),
            "samples_per_s": round(statistics.median(rates))}


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--label", default="")
    parser.add_argument("windows", nargs="+", metavar="RUN@FROM-TO")
    args = parser.parse_args(argv)
    runs = []
    for item in args.windows:
        path, _, span = item.rpartition("@")
        start, _, end = span.partition("-")
        runs.append(window_rate(Path(path), float(start), float(end)))
    print(json.dumps({"label": args.label, "runs": runs,
                      "aggregate_samples_per_s": sum(r["samples_per_s"] for r in runs)}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
