"""The NR counting rule (EVALUATION.md), written once for MJX (batched, jax.numpy) and the CPU
player (scalars, numpy).

An episode runs to its horizon H: 600 steps (20 s at 30 Hz) for a looping clip, to the clip's end
otherwise; the env's own time limit does not cut it short. Its first failed step (a fall, or a
state the simulator lost) ends it, and every remaining step counts 0. NR = mean over episodes of
sum(r_t) / H. Fall rate, survival time (steps run, the failing one included) and the pose and
end-effector errors pooled over survived steps are reported beside it.

DeepMimic's text does not say whether Table 2's return is discounted (DEEPMIMIC.md), so the
paper-form NR is also reported discounted (`nr_paper_discounted`): sum(0.95^t r_t) over the
horizon, over the same sum with r_t = 1. With the original's discount 0.95 it weighs mostly the
first second after the start, where RSI puts the character on the reference.
"""

from __future__ import annotations

from typing import Any

import numpy as np

FIELDS = ("reward", "reward_paper", "reward_paper_discounted", "steps", "failed", "ok_steps", "pose", "ee")
PAPER_DISCOUNT = 0.95  # the original's PPO discount


def start(shape: Any, xp: Any) -> dict[str, Any]:
    zeros = xp.zeros(shape)
    return {"reward": zeros, "reward_paper": zeros, "reward_paper_discounted": zeros, "steps": zeros,
            "failed": zeros > 1, "ok_steps": zeros, "pose": zeros, "ee": zeros, "alive": zeros < 1}


def add_step(acc: dict[str, Any], k: Any, horizon: Any, reward: Any, reward_paper: Any, failed: Any,
             clip_end: Any, pose_error: Any, ee_error: Any, xp: Any) -> dict[str, Any]:
    """Count control step k (0-based) of every episode still running."""
    active = acc["alive"] & (k < horizon)
    fail = active & failed
    ok = active & ~fail
    return {
        "reward": acc["reward"] + xp.where(active, reward, 0.0),
        "reward_paper": acc["reward_paper"] + xp.where(active, reward_paper, 0.0),
        "reward_paper_discounted": acc["reward_paper_discounted"]
        + xp.where(active, PAPER_DISCOUNT ** k * reward_paper, 0.0),
        "steps": acc["steps"] + active,
        "failed": acc["failed"] | fail,
        "ok_steps": acc["ok_steps"] + ok,
        "pose": acc["pose"] + xp.where(ok, pose_error, 0.0),
        "ee": acc["ee"] + xp.where(ok, ee_error, 0.0),
        "alive": active & ~fail & ~clip_end,
    }


def summarize(acc: dict[str, Any], horizon: Any, control_dt: float) -> dict[str, Any]:
    """Per-episode sums (host arrays) -> the EVALUATION.md numbers: `nr` under the training reward
    (the released form unless the run says otherwise) and `nr_paper` under the paper's."""
    acc = {k: np.asarray(v, dtype=np.float64) for k, v in acc.items()}
    horizon = np.asarray(horizon, dtype=np.float64)
    ok = max(float(acc["ok_steps"].sum()), 1.0)
    per_episode = acc["reward"] / horizon
    return {
        "nr": float(per_episode.mean()),
        "nr_std": float(per_episode.std()),
        "nr_paper": float((acc["reward_paper"] / horizon).mean()),
        "nr_paper_discounted": float((acc["reward_paper_discounted"] * (1 - PAPER_DISCOUNT)
                                      / (1 - PAPER_DISCOUNT ** horizon)).mean()),
        "fall_rate": float(acc["failed"].mean()),
        "survival_s": float(acc["steps"].mean() * control_dt),
        "pose_error_rad": float(acc["pose"].sum() / ok),
        "end_effector_error_m": float(acc["ee"].sum() / ok),
        "mean_horizon_steps": float(horizon.mean()),
        "episodes": int(per_episode.size),
    }


def grid_starts(limit: Any, step: float) -> np.ndarray:
    """Start times every `step` seconds over [0, limit), the interval the evaluation draws from:
    `--grid`'s, on MJX and on MuJoCo C alike."""
    return np.arange(0.0, float(limit), step)


def fall_windows(starts: list[float], fell: list[bool]) -> list[list[float]]:
    """[first, last, count] of each run of start times, in clip-time order, that all fell: where in
    a clip a policy cannot be started (a take-off no policy can complete, say), apart from the
    evaluation's draw."""
    windows: list[list[float]] = []
    previous_fell = False
    for t, f in sorted(zip(starts, fell)):
        if f and previous_fell:
            windows[-1][1:] = [t, windows[-1][2] + 1]
        elif f:
            windows.append([t, t, 1])
        previous_fell = f
    return windows
