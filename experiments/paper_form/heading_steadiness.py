"""How steady each clip's root heading is under the two definitions of env.observation_heading:
the yaw of the root's forward axis (DeepMimic's, `forward`) and the twist of its rotation about
the vertical (`twist`). Per clip: the shortest horizontal part of the forward axis over the
frames, the largest and mean change of each heading between two frames of the reference itself,
and how far each heading moves when every frame's root is turned by 3 degrees about a random
axis (median and 90th percentile over the frames, seed 0).

    python experiments/paper_form/heading_steadiness.py [CLIP ...] [--json OUT]   # default: all 15
"""

import argparse
import json

import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.character import load_character
from mjxmimic.motion.clip import load_clip_source

CLIPS = ("walk run backflip spin roll getup_faceup cartwheel punch kick spinkick getup_facedown jump dance_a "
         "dance_b crawl").split()


def _wrapped_degrees(a: np.ndarray) -> np.ndarray:
    return np.degrees(np.abs(quat.wrap_angle(a)))


def steadiness(root_quats: np.ndarray, nudge_deg: float = 3.0, seed: int = 0) -> dict[str, float]:
    axes = np.random.default_rng(seed).normal(size=(len(root_quats), 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    nudged = quat.mul(root_quats, quat.from_rotvec(axes * np.radians(nudge_deg)), np)
    forward_axis = quat.rotate(root_quats, np.array([1.0, 0.0, 0.0]), np)
    out = {"forward_axis_horizontal_min": float(np.linalg.norm(forward_axis[:, :2], axis=1).min())}
    for kind in ("forward", "twist"):
        yaw = quat.heading(root_quats, np, kind)
        steps = _wrapped_degrees(np.diff(yaw))
        moved = _wrapped_degrees(quat.heading(nudged, np, kind) - yaw)
        out.update({f"{kind}_frame_step_max_deg": float(steps.max()),
                    f"{kind}_frame_step_mean_deg": float(steps.mean()),
                    f"{kind}_nudge_median_deg": float(np.median(moved)),
                    f"{kind}_nudge_p90_deg": float(np.percentile(moved, 90))})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clips", nargs="*", default=list(CLIPS))
    parser.add_argument("--json", help="write the rows here")
    args = parser.parse_args()
    character = load_character()
    rows = {name: steadiness(np.asarray(load_clip_source(name, character).qpos)[:, 3:7])
            for name in args.clips}
    print("| clip | forward axis, shortest horizontal part "
          "| largest step between frames, forward / twist (deg) "
          "| 3 degree nudge, median / 90th percentile, forward (deg) | the same, twist (deg) |")
    print("|---|---:|---:|---:|---:|")
    for name, r in rows.items():
        print(f"| {name} | {r['forward_axis_horizontal_min']:.2f} "
              f"| {r['forward_frame_step_max_deg']:.1f} / {r['twist_frame_step_max_deg']:.1f} "
              f"| {r['forward_nudge_median_deg']:.1f} / {r['forward_nudge_p90_deg']:.1f} "
              f"| {r['twist_nudge_median_deg']:.1f} / {r['twist_nudge_p90_deg']:.1f} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
