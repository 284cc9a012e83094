"""Plot evaluation NR (released five-term form) against samples and against wall-clock seconds for
the run folders under experiments/core_v2 (one line per run: walk on warp and on jax, backflip on warp).

    python benchmarks/plot_backends.py
    python benchmarks/plot_backends.py --runs experiments/core_v2 --out experiments/core_v2/learning_warp_vs_jax.png

Reads each run's config.json (clip, physics.backend, run.target_nr) and the evaluation rows of its
metrics.jsonl (`eval/nr`, `step` = samples, `wall` = seconds since the command's start,
compilation and evaluations included).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
COLORS = {"walk_warp": "tab:green", "walk_jax": "tab:blue", "bf_warp": "tab:red"}


def load(run: Path) -> tuple[dict, list[dict], float | None]:
    """(config, evaluation rows, wall-clock of the first training iteration) of one run folder."""
    config = json.loads((run / "config.json").read_text())
    rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines() if line.strip()]
    evals = sorted((r for r in rows if "eval/nr" in r), key=lambda r: r["step"])
    first = min((r["wall"] for r in rows if "eval/nr" not in r and r.get("iteration") == 1), default=None)
    return config, evals, first


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, default=ROOT / "experiments" / "core_v2")
    parser.add_argument("--out", type=Path, default=ROOT / "experiments" / "core_v2" / "learning_warp_vs_jax.png")
    args = parser.parse_args()
    runs = sorted(p for p in args.runs.iterdir() if (p / "metrics.jsonl").is_file() and (p / "config.json").is_file())
    if not runs:
        raise SystemExit(f"no run folders (config.json + metrics.jsonl) under {args.runs}")
    fig, (ax_s, ax_t) = plt.subplots(1, 2, figsize=(11, 4.6), sharey=True)
    targets: dict[float, str] = {}
    for run in runs:
        config, evals, first = load(run)
        if not evals:
            continue
        clip, backend = config["clip"]["name"], config["physics"]["backend"]
        style = "--" if clip != "walk" else "-"
        kw = dict(marker="o", linestyle=style, color=COLORS.get(run.name))
        shown = "auto = warp on a GPU" if backend == "auto" else backend
        label = f"{run.name} ({clip}, physics.backend={shown})"
        nr = [r["eval/nr"] for r in evals]
        ax_s.plot([r["step"] / 1e6 for r in evals], nr, label=label, **kw)
        ax_t.plot([r["wall"] for r in evals], nr, label=label, **kw)
        if first is not None:  # end of the first training iteration: compilation done
            ax_t.axvline(first, color=kw["color"], alpha=0.35, linewidth=1, linestyle=style)
        target = config["run"].get("target_nr")
        if target:
            targets.setdefault(target, clip)
    for ax in (ax_s, ax_t):
        ax.set_xlim(left=0)
        for target, clip in targets.items():
            ax.axhline(target, color="grey", linewidth=0.8, linestyle=":")
            ax.text(ax.get_xlim()[0], target, f" target {clip} {target:g}", fontsize=7, va="bottom", color="grey")
        ax.grid(True, alpha=0.3)
    ax_s.set_xlabel("samples (millions, 30 Hz policy steps)")
    ax_t.set_xlabel("wall-clock s since the command's start (faint vertical: first iteration done)")
    ax_s.set_ylabel("NR (released five-term form, 64 episodes)")
    ax_s.set_ylim(0, 1)
    handles, labels = ax_s.get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="lower center", ncol=3)
    fig.suptitle("gpu preset, one NVIDIA H200 per run, 2026-11-23: MJX warp vs jax backend", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
