"""The time-to-skill table of `s14/`, `s38/`, `s43/` and `s44/` (issue 20): per run, its GPUs, seed,
samples and seconds to the target NR (or its best NR when it never got there, or where the
device call's time limit cut it), its start (first iteration done), its evaluations' seconds and
its steady samples/s; then the medians per setting and each 2-GPU setting's ratio to the 1-GPU
runs of the same code (with a bootstrap interval), also as it would be if the evaluations, and
the start, took no time; last, per setting, the training reward at equal PPO iterations (of
those whose rows every record kept), to show whether a setting learns per iteration or per sample.

    python experiments/multi_gpu/time_to_skill.py [FOLDER ...]     # default: s14, s38, s43, s44
"""

import json
import re
import statistics
import sys
from pathlib import Path

import numpy as np

# a run's name (b1_s3: setting b1, seed 3) -> its setting; each 2-GPU setting against the 1-GPU runs
# of the same code (2026-11-27's for s14 and s38, 2026-11-30's for s43 and s44), the split "s" also
# against the older ones, as first reported
OLD, NEW = "1 GPU, code of 11-27", "1 GPU, code of 11-30"
SETTINGS = {"b1": OLD, "b1n": NEW, "b2a": "2 GPUs, a",
            "b2d": "2 GPUs, d", "b2e": "2 GPUs, e", "b2s": "2 GPUs, s"}
BASELINES = [("2 GPUs, a", OLD), ("2 GPUs, d", OLD), ("2 GPUs, e", OLD),
             ("2 GPUs, s", NEW), ("2 GPUs, s", OLD)]


def records(folder: Path) -> tuple[str, int, list[dict]]:
    """A run folder's setting and seed (from its name, e.g. b2a_s6) and its metrics rows."""
    setting, seed = folder.name.rsplit("_s", 1)
    return SETTINGS[setting], int(seed), [json.loads(line) for line in open(folder / "metrics.jsonl")]


def run_row(folder: Path) -> dict:
    setting, seed, rows = records(folder)
    evals = [r for r in rows if "eval/nr" in r]
    end = next(r for r in rows if "run/samples" in r)
    log = (folder / "train.log").read_text()
    start = re.search(r"; (\d+) s since the start", log)
    return {"run": folder.name, "setting": setting, "seed": seed,
            "samples_m": end["run/samples"] / 1e6, "seconds": end.get("run/time_to_skill_s"),
            # stopped by run.max_seconds (the device call's time) before the target: a lower bound
            "cut_s": end["run/train_seconds"] if ": max_seconds after" in log else None,
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


def median_or_none(runs: list[dict]) -> float | None:
    """Median seconds to the target, a cut run counting as the seconds it had (a lower bound);
    None where a run missed the target or the median would rest on a cut run's bound."""
    if any(r["seconds"] is None and r["cut_s"] is None for r in runs):
        return None
    times = sorted(r["seconds"] if r["seconds"] is not None else r["cut_s"] for r in runs)
    value = statistics.median(times)
    return None if any(r["seconds"] is None and r["cut_s"] < value for r in runs) else value


def bootstrap_ratio(two: list[float], one: list[float], draws: int = 20000) -> tuple[float, float]:
    """90 % interval of the ratio of medians, each setting's runs drawn again with replacement."""
    rng = np.random.default_rng(0)
    a = np.median(rng.choice(two, (draws, len(two))), axis=1)
    b = np.median(rng.choice(one, (draws, len(one))), axis=1)
    return tuple(np.quantile(a / b, [0.05, 0.95]))


def main(roots: list[Path]) -> None:
    rows = [run_row(f) for f in run_folders(roots)]
    print("| run | GPUs and setting | seed | samples to NR 0.75 | seconds to NR 0.75 | first iteration done | "
          "evaluations | steady samples/s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        if r["seconds"] is not None:
            samples, seconds = f"{r['samples_m']:.0f} M", f"{r['seconds']:.0f} s"
        elif r["cut_s"] is not None:
            samples = f"not in {r['samples_m']:.0f} M, cut by the call (best {r['best_nr']:.3f})"
            seconds = f"> {r['cut_s']:.0f} s"
        else:
            samples, seconds = f"not in {r['samples_m']:.0f} M (best {r['best_nr']:.3f})", "-"
        print(f"| `{r['run']}` | {r['setting']} | {r['seed']} | {samples} | {seconds} | {r['start_s']} s | "
              f"{r['eval_s']:.0f} s | {r['samples_per_s'] / 1e3:,.1f} k |")
    warm = [r for r in rows if r["start_s"] <= 25]  # the compilation cache and Warp's kernel cache warm
    print("\nRuns that started warm (first iteration done within 25 s; a run cut by the call counts as the "
          "seconds it had):")
    by_setting = {s: [r for r in warm if r["setting"] == s] for s in SETTINGS.values()}
    by_setting = {s: runs for s, runs in by_setting.items() if runs}
    medians = {s: median_or_none(runs) for s, runs in by_setting.items()}
    for setting, runs in by_setting.items():
        times = sorted(round(r["seconds"]) for r in runs if r["seconds"] is not None)
        cut = [f">{r['cut_s']:.0f}" for r in runs if r["cut_s"] is not None and r["seconds"] is None]
        print(f"- {setting}: {len(runs)} runs, {len(times)} reached the target; seconds {times}"
              + (f", cut {cut}" if cut else "")
              + (f", median {medians[setting]:.0f} s" if medians[setting] else ", median undefined (misses)"))
    # each ratio, then as it would be if the evaluations, and then also the start, took no time: the
    # part of the gap that the second GPU's training speed cannot close (runs that reached it)
    for setting, one in BASELINES:
        if not (medians.get(setting) and medians.get(one)):
            continue
        times = ([r["seconds"] or r["cut_s"] for r in by_setting[s]] for s in (setting, one))
        low, high = bootstrap_ratio(*times)
        print(f"- ratio of medians, {setting} / {one}: {medians[setting] / medians[one]:.2f} "
              f"(bootstrap 90 % interval {low:.2f} to {high:.2f})")
        for label, cost in (("evaluations", lambda r: r["eval_s"]),
                            ("evaluations and start", lambda r: r["eval_s"] + r["start_s"])):
            less = [statistics.median(r["seconds"] - cost(r) for r in by_setting[s] if r["seconds"])
                    for s in (setting, one)]
            print(f"  - without the {label}: {less[0]:.0f} s / {less[1]:.0f} s = {less[0] / less[1]:.2f}")


if __name__ == "__main__":
    here = Path(__file__).parent
    folders = [Path(a) for a in sys.argv[1:]] or [here / name for name in ("s14", "s38", "s43", "s44")]
    main(folders)
    per_iteration(folders)
