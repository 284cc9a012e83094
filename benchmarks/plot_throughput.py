"""Plot samples/s against env count from `mjxmimic bench --out` JSON files (one line per kind).

    python benchmarks/plot_throughput.py benchmarks/results/bench_gpu_h200_warp.json \
        benchmarks/results/bench_gpu_h200_preset.json --out benchmarks/throughput.png

Rows without a "backend" field come from files written before the env core v2 (issue 12), when
MJX's impl='jax' was the only GPU backend; they are labelled jax.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from mjxmimic.ops.bench import solver_label  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", type=Path, nargs="+")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    fig, ax = plt.subplots(figsize=(6, 4))
    colors = {"physics_only": "tab:blue", "env_step": "tab:orange", "train_loop": "tab:green"}
    for path, style in zip(args.results, ("-", "--", ":", "-.")):  # one line style per file
        data = json.loads(path.read_text())
        device = data["info"]["device"]
        for kind, color in colors.items():
            rows = sorted((r for r in data["rows"] if r["kind"] == kind), key=lambda r: r["num_envs"])
            if rows:
                ax.plot([r["num_envs"] for r in rows], [r["samples_per_s"] for r in rows], marker="o",
                        color=color, linestyle=style,
                        label=f"{kind} ({device}, {rows[0].get('backend', 'jax')}, {rows[0]['physics_hz']} Hz, "
                              f"{solver_label(rows[0])} it)")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("parallel environments")
    ax.set_ylabel("samples/s (30 Hz policy steps)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)


if __name__ == "__main__":
    main()
