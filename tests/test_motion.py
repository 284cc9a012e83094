"""Motion library: frames reproduced, smooth cycles, velocities consistent with poses."""

import numpy as np
import pytest

from mjxmimic.motion import library as motion
from mjxmimic.core import quat
from mjxmimic.motion.clip import load_clip


@pytest.fixture(scope="module")
def walk(deepmimic_dir, character):
    clip = load_clip(deepmimic_dir / "motions" / "humanoid3d_walk.txt", character)
    return clip, motion.build_motion_lib([clip], character)


def test_frames_are_reproduced(walk):
    clip, lib = walk
    for f in (0, 5, 17):
        qpos, _ = motion.sample(lib, 0, clip.frame_times[f])
        np.testing.assert_allclose(qpos, clip.qpos[f], atol=1e-5)


def test_cycles_continue_forward_and_join_smoothly(walk):
    clip, lib = walk
    dur = clip.duration
    before, _ = motion.sample(lib, 0, dur - 1e-4)
    after, _ = motion.sample(lib, 0, dur + 1e-4)
    np.testing.assert_allclose(after[:2], before[:2], atol=5e-3)  # the root does not jump back
    np.testing.assert_allclose(after[7:], clip.qpos[0, 7:], atol=5e-3)  # the next cycle starts anew ...
    turned = quat.mul(quat.from_yaw(lib.cycle_yaw[0]), clip.qpos[0, 3:7])  # ... turned as the last frame
    np.testing.assert_allclose(after[3:7], turned, atol=5e-3)
    assert abs(quat.heading(after[3:7]) - quat.heading(before[3:7])) < 5e-3  # heading carried on
    far, _ = motion.sample(lib, 0, 3 * dur)
    start, _ = motion.sample(lib, 0, 0.0)
    travel = np.linalg.norm(far[:2] - start[:2])
    assert travel == pytest.approx(3 * clip.root_travel, rel=0.05)  # three cycles, still walking


def test_velocities_match_pose_differences(walk):
    clip, lib = walk
    layout = lib.layout
    dt = 1e-3
    for t in (0.21, 0.77, 1.9):
        q0, v = motion.sample(lib, 0, t)
        q1, _ = motion.sample(lib, 0, t + dt)
        np.testing.assert_allclose((q1[:3] - q0[:3]) / dt, v[:3], atol=0.15)
        a, b = q0[layout.q_quat[3]], q1[layout.q_quat[3]]  # a ball joint (hip)
        w = quat.to_rotvec(quat.mul(quat.conj(a), b)) / dt
        np.testing.assert_allclose(w, v[layout.v_ang[3]], atol=0.4)
