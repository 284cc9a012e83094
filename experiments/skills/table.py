"""The skill-suite table: for each run folder given (default: the folders beside this script), its
paper-form NR beside DeepMimic's Table 2 (the clip from its config), its released-form NR (none
for a run trained on the paper form, whose eval/nr is that form's), the samples and seconds to reach
the paper's NR (or its best within the run), the final evaluation and its fall rate, and the best
policy's NR on MuJoCo C with its ratio to the MJX NR (RUN/play_cpu_64_converged.json, from
`mjxmimic play POLICY --episodes 64 --json`, where the run has one); then the frame strip of each
run that has one (RUN/strip.png, from `mjxmimic render RUN/policy.npz --out RUN/strip.png --ghost
--seconds CLIP_SECONDS`). Runs recorded before the tenth session of 2026-11-26 hold the mixed paper
form in eval/nr_paper (experiments/README.md); Table 2 is set beside whatever form the rows hold.

    python experiments/skills/table.py [RUN ...] > table.md
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

PLAY = "play_cpu_64_converged.json"  # MuJoCo C with the converged solve (experiments/README.md)

# DeepMimic's Table 2 (paper-form NR), ../shared/docs/DEEPMIMIC.md
PAPER_NR = {"walk": 0.985, "run": 0.951, "jog": 0.951, "jump": 0.947, "crawl": 0.932, "getup_facedown": 0.885,
            "kick": 0.854, "getup_faceup": 0.838, "spin": 0.664, "dance_a": 0.863, "dance_b": 0.822,
            "punch": 0.812, "sideflip": 0.805, "cartwheel": 0.804, "spinkick": 0.748, "roll": 0.735,
            "backflip": 0.729, "frontflip": 0.485}


def evaluations(run: Path) -> list[dict]:
    """The run's evaluations from metrics.jsonl; a run whose metrics did not come back from the
    GPU has only its final evaluation (eval.json)."""
    if not (run / "metrics.jsonl").is_file():
        final = json.loads((run / "eval.json").read_text())
        return [{"step": final["samples"], "wall": final["train_seconds"],
                 **{f"eval/{k}": v for k, v in final.items()}}]
    rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines() if line.strip()]
    return [r for r in rows if "eval/nr_paper" in r]


def row(run: Path) -> str:
    evals = evaluations(run)
    config = json.loads((run / "config.json").read_text()) if (run / "config.json").is_file() else {}
    clip = config.get("clip", {}).get("name", run.name)  # the suite's folders are named after theirs
    paper = PAPER_NR.get(clip)
    best = max(evals, key=lambda r: r["eval/nr_paper"])
    reached = next((r for r in evals if paper is not None and r["eval/nr_paper"] >= paper), None)
    at = reached or best
    verdict = "-" if paper is None else "yes" if reached else "no"
    last = evals[-1]
    # eval/nr is the training form's NR: the released form's only where the run trained on it
    released = "-" if config.get("reward", {}).get("kind") == "paper" else f"{best['eval/nr']:.3f}"
    name = clip if clip == run.name else f"{run.name} ({clip})"
    cpu = "-"
    if (run / PLAY).is_file():
        try:
            played = json.loads((run / PLAY).read_text())["nr_paper"]
        except (ValueError, KeyError, TypeError):
            sys.exit(f"table.py: {run / PLAY}: not the JSON of `mjxmimic play --json` (empty, or still being written?)")
        cpu = f"{played:.3f} ({played / best['eval/nr_paper']:.3f})"
    return (f"| {name} | {paper if paper is not None else '-'} | {best['eval/nr_paper']:.3f} | {released} "
            f"| {verdict} | {at['step'] / 1e6:.0f} M | {at['wall']:.0f} s | {last['eval/nr_paper']:.3f} "
            f"| {last['step'] / 1e6:.0f} M | {last['eval/fall_rate']:.2f} | {cpu} |")


def is_run(path: Path) -> bool:
    return (path / "metrics.jsonl").is_file() or (path / "eval.json").is_file()


def main(paths: list[str]) -> None:
    if any(p in ("-h", "--help") for p in paths):
        print(__doc__)
        return
    runs = [Path(p) for p in paths] or sorted(p for p in Path(__file__).parent.iterdir() if is_run(p))
    for run in runs:
        if not is_run(run):
            sys.exit(f"table.py: {run}: not a run record (no metrics.jsonl or eval.json there)")
    rows = [row(run) for run in runs]  # before any output: a bad record stops with one line only
    print("| clip | paper NR (Table 2) | best NR, paper form | released form | reached paper | samples | "
          "seconds | final NR, paper form | final samples | final fall rate | MuJoCo C (ratio) |")
    print("|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---|")
    print("\n".join(rows))
    for run in runs:
        if (run / "strip.png").is_file():
            print(f"\n{run.name} (the policy in grey, its reference as an orange ghost):\n\n![{run.name}]({run.name}/strip.png)")


if __name__ == "__main__":
    main(sys.argv[1:])
