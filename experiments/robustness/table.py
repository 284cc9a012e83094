"""The push table of graded run records (issue 17): per run folder, its clip, samples, best
checkpoint, the policy's exploration std there, NR on MJX (released form, paper form as written
in brackets), CPU / MJX NR, the push test on MJX (push.json) and on MuJoCo C (push_cpu.json)
beside Table 6 and 1.5 x Table 6, the NR cost against the preset's 100 M policy of the clip
without pushes (../skills_100m/CLIP), or against the runs given after --baselines (the one of
the same clip and seed, else the clip's only one), and the mean NR of the last five evaluations
with its cost against the baseline's (less hostage to one lucky evaluation than the best
checkpoint). With --summary, then per clip and seed: the runs' mean best NR, its standard
deviation and its mean cost. The files are those that `experiments/device_train.sh`'s grade_NAME
writes.

    python experiments/robustness/table.py experiments/robustness/root_frame/*
    python experiments/robustness/table.py experiments/robustness/sideways/* --baselines \
        experiments/robustness/sideways/r200 experiments/robustness/sideways/b200
    cd experiments/robustness && python table.py sideways/bcS second_seed/bcS_s1 \
        push_share_stop/bcS[YLIKMNO]* --summary --baselines sideways/b200 second_seed/b200_s1 third_seed/b200_s2
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

from mjxmimic.commands.evaluate import PAPER_PUSH_N
from mjxmimic.core.config import has_pushes
from mjxmimic.runs import folder, metrics_log

BASELINES = Path(__file__).resolve().parent.parent / "skills_100m"


def _json(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def _forces(result: dict | None) -> str:
    return f"{result['push_forward_n']:.0f} / {result['push_sideways_n']:.0f} N" if result else "-"


def _std_at(run: Path, checkpoint: int) -> str:
    """The policy's mean std (policy/std) in the last training row logged at or before
    `checkpoint`: what the policy had learnt to explore with when it was graded."""
    stds = [d["policy/std"] for d in metrics_log.read(run) if "policy/std" in d and d["step"] <= checkpoint]
    return f"{stds[-1]:.3f}" if stds else "-"


def _last_evals_mean(run: Path, count: int = 5) -> float:
    """The mean released-form NR of the run's last `count` evaluations (one per step: a resumed
    run's log may hold a step twice)."""
    by_step = {d["step"]: d["eval/nr"] for d in metrics_log.read(run) if "eval/nr" in d}
    last = [by_step[step] for step in sorted(by_step)[-count:]]
    return sum(last) / len(last)


def _baseline(config, baselines: dict[tuple[str, int], Path]) -> Path:
    """The baseline of the run's clip and seed, else the clip's only one, else the 100 M suite's."""
    clip, seed = config.clip.name, config.run.seed
    of_clip = [path for (name, _), path in baselines.items() if name == clip]
    return baselines.get((clip, seed), of_clip[0] if len(of_clip) == 1 else BASELINES / clip)


def row(run: Path, baselines: dict[tuple[str, int], Path]) -> str:
    config = folder.load_config(run)
    clip = config.clip.name
    best = folder.read_best(run)
    nr = best["eval"]["nr"]
    cpu = _json(run / "play_cpu.json")
    base = _baseline(config, baselines)
    baseline = folder.read_best(base) if base.is_dir() else None
    cost = f"{baseline['eval']['nr'] - nr:.3f}" if baseline else "-"
    last = _last_evals_mean(run)
    last_cost = f" ({_last_evals_mean(base) - last:.3f})" if baseline else ""
    cpu_ratio = f"{cpu['nr'] / nr:.3f}" if cpu else "-"
    table6 = PAPER_PUSH_N.get(clip)
    paper = f"{table6[0]} / {table6[1]} N" if table6 else "-"
    target = f"{1.5 * table6[0]:.0f} / {1.5 * table6[1]:.0f} N" if table6 else "-"
    pushes = has_pushes(config.env)
    return (f"| `{run.name}` | {clip} | {'yes' if pushes else 'no'} | {config.env.pose_termination_frame} "
            f"| {config.run.total_samples / 1e6:.0f} M | {best['checkpoint'] / 1e6:.0f} M "
            f"| {_std_at(run, best['checkpoint'])} "
            f"| {nr:.3f} ({best['eval']['nr_paper']:.3f}) | {cost} | {cpu_ratio} "
            f"| {_forces(_json(run / 'push.json'))} | {_forces(_json(run / 'push_cpu.json'))} | {paper} | {target} "
            f"| {last:.3f}{last_cost} |")


def summary(runs: list[Path], baselines: dict[tuple[str, int], Path]) -> list[str]:
    """Per clip and seed: how many runs, their best NRs' mean, standard deviation and range, the
    baseline's best NR (the one of that clip and seed) and the mean cost against it."""
    groups: dict[tuple[str, int], list[float]] = {}
    for run in runs:
        config = folder.load_config(run)
        groups.setdefault((config.clip.name, config.run.seed), []).append(folder.read_best(run)["eval"]["nr"])
    out = ["| clip | seed | runs | best NR: mean | standard deviation | range | baseline | mean cost |",
           "|---|---:|---:|---:|---:|---|---:|---:|"]
    for (clip, seed), nrs in sorted(groups.items()):
        mean = statistics.mean(nrs)
        sd = f"{statistics.stdev(nrs):.3f}" if len(nrs) > 1 else "-"
        base = baselines.get((clip, seed))
        base_nr = folder.read_best(base)["eval"]["nr"] if base is not None else None
        against = f"{base_nr:.3f} | {base_nr - mean:.3f}" if base_nr is not None else "- | -"
        out.append(f"| {clip} | {seed} | {len(nrs)} | {mean:.3f} | {sd} | {min(nrs):.3f} to {max(nrs):.3f} | {against} |")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--baselines", nargs="*", type=Path, default=[],
                        help="runs without pushes, one per clip and seed, to measure the NR cost against")
    parser.add_argument("--summary", action="store_true",
                        help="then the runs' mean best NR and mean cost per clip and seed")
    args = parser.parse_args()
    baselines = {}
    for run in args.baselines:
        config = folder.load_config(run)
        baselines[(config.clip.name, config.run.seed)] = run
    print("| run | clip | pushes | pose termination | samples | best at | std there | NR on MJX | NR cost "
          "| CPU / MJX | push on MJX | push on MuJoCo C | Table 6 | 1.5 x Table 6 | last five (cost) |")
    print("|---|---|---|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for run in args.runs:
        print(row(run, baselines))
    if args.summary:
        print()
        print("\n".join(summary(args.runs, baselines)))


if __name__ == "__main__":
    main()
