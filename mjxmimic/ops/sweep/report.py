"""A sweep's report: the results table (Markdown and CSV) and the learning curves."""

from __future__ import annotations

import csv
import io
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mjxmimic.core import config as config_lib
from mjxmimic.runs import folder
from mjxmimic.runs.metrics_log import read as read_metrics
from mjxmimic.ops.sweep.spec import RunSpec, Spec, cli_value
from mjxmimic.ops.sweep.state import STATE_FILE, now, read_json, is_finished

def run_row(spec: Spec, run: RunSpec, record: dict) -> dict:
    """One results row: status, NR (the final evaluation, else the latest one), fall rate, samples,
    wall-clock and steady-state samples/s (eval.json, else metrics.jsonl)."""
    run_dir = spec.run_dir(run)
    row: dict[str, Any] = {"run": run.name, "clip": run.clip, "seed": run.seed, "nr": None, "fall_rate": None,
                           "nr_at_samples": None, "samples": None, "wall_s": None, "samples_per_s": None}
    status = record.get("status") or "pending"
    if is_finished(run_dir, run.config):
        status = "finished"
    metrics = read_metrics(run_dir)
    final = read_json(folder.eval_path(run_dir)) if status == "finished" else None
    if final is not None:
        row.update(nr=final.get("nr"), fall_rate=final.get("fall_rate"), nr_at_samples=final.get("samples"),
                   samples=final.get("samples"), wall_s=final.get("train_seconds"),
                   samples_per_s=final.get("samples_per_s_steady"))
    elif metrics:
        evals = [m for m in metrics if "eval/nr" in m]
        if evals:
            row.update(nr=evals[-1]["eval/nr"], fall_rate=evals[-1].get("eval/fall_rate"),
                       nr_at_samples=evals[-1]["step"])
        row.update(samples=max(m.get("step", 0) for m in metrics), wall_s=max(m.get("wall", 0.0) for m in metrics))
        steady = [m["run/samples_per_s_steady"] for m in metrics if "run/samples_per_s_steady" in m]
        if steady:
            row["samples_per_s"] = steady[-1]
    if status == "failed" and record.get("exit_code") is not None:
        rc = record["exit_code"]
        status = f"failed ({'signal ' + str(-rc) if rc < 0 else 'exit ' + str(rc)})"
    row["status"] = status
    return row


def _config_value(cfg: config_lib.Config, key: str) -> Any:
    section, name = key.split(".")
    value = getattr(getattr(cfg, section), name)
    return list(value) if isinstance(value, tuple) else value


def _rows(spec: Spec, state: dict) -> tuple[list[str], list[dict]]:
    keys = spec.varying_keys
    rows = []
    for run in sorted(spec.runs, key=lambda r: r.order):
        row = run_row(spec, run, state.get("runs", {}).get(run.name, {}))
        row["overrides"] = {k: _config_value(run.config, k) for k in keys}
        rows.append(row)
    return keys, rows


def _fmt(value: Any, kind: str) -> str:
    if value is None:
        return "-"
    if kind == "nr":
        return f"{value:.3f}"
    if kind == "fall":
        return f"{value:.2f}"
    if kind == "int":
        return f"{int(value):,}"
    if kind == "s":
        return f"{value:,.0f}"
    if isinstance(value, list):
        return "x".join(str(v) for v in value)
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


CSV_COLUMNS = ("nr", "fall_rate", "nr_at_samples", "samples", "wall_s", "samples_per_s")


def write_tables(spec: Spec, state: dict) -> tuple[Path, Path]:
    """OUT/report.md and OUT/report.csv: one row per run of the spec, in clip/grid/runs/seed order."""
    keys, rows = _rows(spec, state)
    out = spec.out
    out.mkdir(parents=True, exist_ok=True)

    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow(["run", "clip", *keys, "seed", "status", *CSV_COLUMNS])
    for r in rows:
        writer.writerow([r["run"], r["clip"],
                         *[(";".join(str(x) for x in v) if isinstance(v, list) else v)
                           for v in r["overrides"].values()],
                         r["seed"], r["status"], *["" if r[c] is None else r[c] for c in CSV_COLUMNS]])
    csv_path = out / "report.csv"
    csv_path.write_text(buf.getvalue())

    lines = [f"# Sweep {spec.name}", ""]
    if spec.description:
        lines += [spec.description, ""]
    common = ", ".join(f"`{k}={cli_value(v)}`" for k, v in spec.common.items()) or "none"
    lines += [f"Spec `{spec.path}`; preset `{spec.preset}`; common overrides: {common}.",
              (f"Written {now()}. NR and fall rate are the final evaluation's (EVALUATION.md) for finished "
               "runs, else the latest periodic evaluation's, at the samples in column 'NR at'. Wall-clock is "
               "the training's (compilation included, summed over resumed calls); samples/s is the steady "
               "state of the run's last call."), ""]
    devices = sorted({d for r in spec.runs if (d := (read_json(folder.eval_path(spec.run_dir(r))) or {}).get('device'))})
    if devices:
        lines += [f"Device: {', '.join(devices)}.", ""]
    header = ["run", "clip", *[f"`{k}`" for k in keys], "seed", "status", "NR", "fall rate", "NR at",
              "samples", "wall-clock s", "samples/s"]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        cells = [r["run"], r["clip"], *[_fmt(v, "") for v in r["overrides"].values()], str(r["seed"]), r["status"],
                 _fmt(r["nr"], "nr"), _fmt(r["fall_rate"], "fall"), _fmt(r["nr_at_samples"], "int"),
                 _fmt(r["samples"], "int"), _fmt(r["wall_s"], "s"), _fmt(r["samples_per_s"], "s")]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    if any(r["status"] == "pruned" for r in rows):
        lines += ["", ("Pruned: stopped early by the Ray Tune scheduler of the spec's \"ray\" block (the training "
                       "checkpointed); NR is its last evaluation before that. Later sweep calls leave it so.")]
    failures = [(r, state.get("runs", {}).get(r["run"], {})) for r in rows if r["status"].startswith("failed")]
    if failures:
        lines += ["", "## Failed runs", ""]
        for r, rec in failures:
            last = (rec.get("log_tail") or ["(no output)"])[-1]
            lines.append(f"- `{r['run']}`: {r['status']}: `{last}` (log: `{rec.get('log', '')}`)")
    lines += ["", "Learning curves: `curves.png`.", ""]
    md_path = out / "report.md"
    md_path.write_text("\n".join(lines))
    return md_path, csv_path


def write_curves(spec: Spec) -> Path | None:
    """OUT/curves.png: evaluation NR against samples and against wall-clock, and training reward
    (mean per step) against samples; one line per run, one colour per configuration, one line
    style per seed. Returns None (and says why) when matplotlib is missing or nothing was logged."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise _NoPlot("matplotlib is not installed, so no curves.png (pip install matplotlib)") from None
    series = []
    for run in sorted(spec.runs, key=lambda r: r.order):
        metrics = read_metrics(spec.run_dir(run))
        if metrics:
            series.append((run, metrics))
    if not series:
        raise _NoPlot("no run has logged metrics yet, so no curves.png")
    configs = []
    for run, _ in series:
        key = (run.order[0], run.order[1], run.order[2])
        if key not in configs:
            configs.append(key)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles = ["-", "--", ":", "-."]
    fig, axes = plt.subplots(1, 3, figsize=(17, 4.8))
    for run, metrics in series:
        ci = configs.index((run.order[0], run.order[1], run.order[2]))
        style = {"color": colors[ci % len(colors)], "linestyle": styles[run.order[3] % len(styles)],
                 "label": run.name}
        evals = [m for m in metrics if m.get("eval/nr") is not None]
        if evals:
            axes[0].plot([m["step"] for m in evals], [m["eval/nr"] for m in evals], marker="o", ms=3, **style)
            axes[1].plot([m["wall"] for m in evals], [m["eval/nr"] for m in evals], marker="o", ms=3, **style)
        train = [m for m in metrics if m.get("reward") is not None]
        if train:
            axes[2].plot([m["step"] for m in train], [m["reward"] for m in train], **style)
    titles = [("evaluation NR", "samples"), ("evaluation NR", "wall-clock s (compilation included)"),
              ("training reward per step", "samples")]
    for ax, (title, xlabel) in zip(axes, titles):
        ax.set_title(title)
        ax.set_xlabel(xlabel)
        ax.grid(alpha=0.3)
        if not ax.lines:
            ax.text(0.5, 0.5, "no data yet", ha="center", va="center", transform=ax.transAxes)
    for ax in axes:
        ax.set_xlim(left=0)
    axes[0].set_ylim(0, 1)
    axes[1].set_ylim(0, 1)
    handles, labels = axes[2].get_legend_handles_labels()
    if not handles:
        handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(4, max(1, len(labels))), fontsize=8)
    fig.suptitle(f"sweep {spec.name}")
    fig.tight_layout(rect=(0, 0.05 + 0.03 * ((len(labels) - 1) // 4), 1, 1))
    path = spec.out / "curves.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


class _NoPlot(Exception):
    pass


def write_report(spec: Spec, echo: Callable[[str], None] = print) -> list[Path]:
    """report.md, report.csv and (with matplotlib) curves.png in OUT; returns the paths written."""
    state = read_json(spec.out / STATE_FILE) or {}
    paths = list(write_tables(spec, state))
    try:
        png = write_curves(spec)
    except _NoPlot as why:
        echo(f"note: {why}")
    else:
        paths.append(png)
    return paths
