"""The time-to-skill table of `s14/`, `s38/` and `s43/` (issue 20): per run, its GPUs, seed,
samples and seconds to the target NR (or its best NR when it never got there), its start (first
iteration done), its evaluations' seconds and its steady samples/s; then the medians per setting
and their ratios, also as they would be if the evaluations, and the start, took no time; last,
per setting, the training reward at equal PPO iterations (of those whose rows every record
kept), to show whether a setting learns per iteration or per sample.

    python experiments/multi_gpu/time_to_skill.py [FOLDER ...]     # default: s14, s38 and s43
"""

import json
import re
import statistics
import sys
from pathlib import Path

SETTINGS = {"b1": "1 GPU", "b2a": "2 GPUs, a", "b2d": "2 GPUs, d", "b2e": "2 GPUs, e", "b2s": "2 GPUs, s"}


def records(folder: Path) -> tuple[str, int, list[dict]]:
    """A run folder's setting and seed (from its name, e.g. b2a_s6) and its metrics rows."""
    setting, seed = folder.name.rsplit("_s", 1)
    return SETTINGS[setting], int(seed), [json.loads(line) for line in open(folder / "metrics.jsonl")]


def run_row(folder: Path) -> dict:
    setting, seed, rows = records(folder)
    evals = [r for r in rows if "eval/nr" in r]
    end = next(r for r in rows if "run/samples" in r)
    start = re.search(r"; (\d+) s since the start", (folder / "train.log").read_text())
    return {"run": folder.name, "setting": setting, "seed": seed,
            "samples_m": end["run/samples"] / 1e6, "seconds": end.get("run/time_to_skill_s"),
            "best_nr": max(r["eval/nr"] for r in evals), "start_s": int(start.group(1)),
            "eval_s": sum(r["eval/eval_seconds"] for r in evals),
            "samples_per_s": end["run/samples_per_s_steady"]}


def run_folders(roots: list[Path]) -> list[Path]:
    return sorted((f for root in roots for f in root.iterdir() if f.is_dir()), key=lambda f: f.name)


def per_iteration(roots: list[Path], iterations: tuple[int, ...] = (110, 210, 310, 410)) -> None:
    """Mean training reward (the stochastic policy's imitation reward per step), samples and
    seconds since the start at the same iterations, over each setting's runs that got there."""
    rows_by_setting: dict[str, list[dict]] = {}
    for folder in run_folders(roots):
        setting, _, rows = records(folder)
        rows_by_setting.setdefault(setting, []).append({r["iteration"]: r for r in rows if "reward" in r})
    print("\n| setting | iteration | runs | samples | training reward | seconds since the start |")
    print("|---|---:|---:|---:|---:|---:|")
    for setting, runs in rows_by_setting.items():
        for it in iterations:
            at = [run[it] for run in runs if it in run]
            if at:
                step, reward, wall = (statistics.mean(r[key] for r in at) for key in ("step", "reward", "wall"))
                print(f"| {setting} | {it} | {len(at)} | {step / 1e6:.1f} M | {reward:.3f} | {wall:.0f} s |")


def main(roots: list[Path]) -> None:
    rows = [run_row(f) for f in run_folders(roots)]
    print("| run | GPUs and setting | seed | samples to NR 0.75 | seconds to NR 0.75 | first iteration done | "
          "evaluations | steady samples/s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        reached = r["seconds"] is not None
        samples = f"{r['samples_m']:.0f} M" if reached else f"not in {r['samples_m']:.0f} M (best {r['best_nr']:.3f})"
        seconds = f"{r['seconds']:.0f} s" if reached else "-"
        print(f"| `{r['run']}` | {r['setting']} | {r['seed']} | {samples} | {seconds} | {r['start_s']} s | "
              f"{r['eval_s']:.0f} s | {r['samples_per_s'] / 1e3:,.1f} k |")
    warm = [r for r in rows if r["start_s"] <= 25]  # the compilation cache and Warp's kernel cache warm
    print("\nRuns that started warm (first iteration done within 25 s):")
    medians = {}
    for setting in SETTINGS.values():
        done = [r for r in warm if r["setting"] == setting]
        if not done:
            continue
        times = [r["seconds"] for r in done if r["seconds"] is not None]
        medians[setting] = statistics.median(times) if len(times) == len(done) else None
        print(f"- {setting}: {len(done)} runs, {len(times)} reached the target; "
              f"seconds {sorted(round(t) for t in times)}" +
              (f", median {medians[setting]:.0f} s" if medians[setting] else ", median undefined (misses)"))
    one = medians.get("1 GPU")
    for setting, value in medians.items():
        if setting != "1 GPU" and one and value:
            print(f"- ratio of medians, {setting} / 1 GPU: {value / one:.2f}")
    # What the ratio would be if the evaluations, and then also the start, took no time: the
    # part of the gap that the second GPU's training speed cannot close.
    for label, cost in (("evaluations", lambda r: r["eval_s"]),
                        ("evaluations and start", lambda r: r["eval_s"] + r["start_s"])):
        less = {}
        for setting in (s for s, value in medians.items() if value):  # settings that always reached it
            done = [r for r in warm if r["setting"] == setting]
            less[setting] = statistics.median(r["seconds"] - cost(r) for r in done)
        for setting, value in less.items():
            if setting != "1 GPU" and "1 GPU" in less:
                print(f"- without the {label}: {setting} {value:.0f} s / 1 GPU {less['1 GPU']:.0f} s = "
                      f"{value / less['1 GPU']:.2f}")


if __name__ == "__main__":
    here = Path(__file__).parent
    folders = [Path(a) for a in sys.argv[1:]] or [here / "s14", here / "s38", here / "s43"]
    main(folders)
    per_iteration(folders)
