"""Motion library: frames reproduced, smooth cycles, velocities consistent with poses."""

import numpy as np
import pytest

from mjxmimic.motion import library as motion
from mjxmimic.core import quat
from mjxmimic.core.errors import UserError
from mjxmimic.motion.clip import Clip, load_clip, load_clip_source


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


# ------------------------------------------------------------------ constant-time lookup, weights

PROJECT = ("slow_walk", "squat", "wave")


@pytest.fixture(scope="module")
def project_clips(character):
    return {name: load_clip_source(name, character) for name in PROJECT}


def _brute_force_frame(lib, clip, tau):
    """The lookup this module did before the grid: count the clip's frames started by tau."""
    in_clip = lib.frame_clip == clip
    return np.array([np.sum(in_clip & (lib.times <= x)) - 1 for x in np.atleast_1d(tau)])


def _lookup(lib, clip, tau):
    return np.array([motion._frame_index(lib, clip, x, np) for x in np.atleast_1d(tau)])


def _hard_times(lib, clip, rng, count=400):
    """Random times plus every frame and grid time and their float32 neighbours, in float32."""
    first, n = lib.clip_start[clip], lib.clip_frames[clip]
    dur = lib.duration[clip]
    marks = np.concatenate([lib.times[first:first + n],
                            np.arange(lib.grid_size[clip], dtype=np.float32) * lib.grid_step[clip]])
    near = np.concatenate([marks, np.nextafter(marks, np.float32(-1)), np.nextafter(marks, np.float32(9))])
    tau = np.concatenate([rng.uniform(0, dur, count).astype(np.float32), near.astype(np.float32)])
    return np.clip(tau, np.float32(0), dur)


def _nonuniform(clip, rng, durations=None):
    """`clip`'s poses with other frame durations (DeepMimic files give one per frame)."""
    if durations is None:
        durations = rng.uniform(0.004, 0.07, clip.num_frames)
    return Clip(name="nonuniform", path=None, loop=True, durations=np.asarray(durations), qpos=clip.qpos)


def _test_clips(project_clips, rng):
    """The project's clips, one with random frame durations, and one whose frame times all lie on
    its grid (durations multiples of 3/32 s, exact in float32), where float division rounds a time
    just before a frame up into that frame's cell."""
    walk = project_clips["slow_walk"]
    on_grid = rng.choice([3, 6, 9], walk.num_frames) / 32
    return list(project_clips.values()) + [_nonuniform(walk, rng), _nonuniform(walk, rng, on_grid)]


def test_lookup_matches_brute_force(project_clips, character):
    rng = np.random.default_rng(0)
    clips = _test_clips(project_clips, rng)
    lib = motion.build_motion_lib(clips, character)
    assert lib.grid_step[-2] < lib.grid_step[0]  # the short frames set the synthetic clip's step
    assert lib.grid_step[-1] == np.float32(3 / 32)
    for c in range(len(clips)):
        tau = _hard_times(lib, c, rng)
        np.testing.assert_array_equal(_lookup(lib, c, tau), _brute_force_frame(lib, c, tau))
        tau64 = rng.uniform(0, lib.duration[c], 300)  # numpy callers may pass float64 times
        np.testing.assert_array_equal(_lookup(lib, c, tau64), _brute_force_frame(lib, c, tau64))
        fixed_rate = c < len(PROJECT)  # one table entry per frame, and one past the end
        assert lib.grid_size[c] <= lib.clip_frames[c] + (2 if fixed_rate else 10 * lib.clip_frames[c])


@pytest.mark.parametrize("nudge", [-2e-3, 2e-3])
def test_lookup_survives_a_cell_index_one_off(project_clips, character, nudge):
    """Division that is not correctly rounded (some accelerators) may put k one cell off either way."""
    rng = np.random.default_rng(5)
    clips = _test_clips(project_clips, rng)
    built = motion.build_motion_lib(clips, character)
    assert built.grid_size.max() * abs(nudge) < 1  # so k is at most one off
    lib = built._replace(grid_step=(built.grid_step * (1 + nudge)).astype(np.float32))
    for c in range(len(clips)):
        tau = np.concatenate([_hard_times(built, c, rng), rng.uniform(0, lib.duration[c], 3000)])
        assert np.any(np.floor(tau / lib.grid_step[c]) != np.floor(tau / built.grid_step[c]))
        np.testing.assert_array_equal(_lookup(lib, c, tau), _brute_force_frame(lib, c, tau))


def test_zero_duration_frame_is_a_clean_jump(project_clips, character):
    rng = np.random.default_rng(1)
    walk = project_clips["slow_walk"]
    durations = np.full(walk.num_frames, 1 / 30)
    durations[[0, 10, 11]] = 0.0  # frames 0, 10 and 11 last no time: poses 1 and 12 take over
    lib = motion.build_motion_lib([_nonuniform(walk, rng, durations)], character)
    tau = _hard_times(lib, 0, rng)
    np.testing.assert_array_equal(_lookup(lib, 0, tau), _brute_force_frame(lib, 0, tau))
    assert lib.grid_size[0] <= walk.num_frames + 2  # equal times are one boundary, not a 0 s gap
    np.testing.assert_array_equal(lib.qvel[0], lib.qvel[1])  # a jump takes its neighbour's velocity
    np.testing.assert_array_equal(lib.qvel[10], lib.qvel[9])
    np.testing.assert_array_equal(lib.qvel[11], lib.qvel[9])
    assert np.all(np.isfinite(lib.qvel))
    qpos, qvel = motion.sample(lib, 0, lib.times[12])
    np.testing.assert_allclose(qpos, walk.qpos[12], atol=1e-5)
    assert np.all(np.isfinite(qvel))


def test_very_short_frame_keeps_the_table_small(project_clips, character):
    rng = np.random.default_rng(2)
    walk = project_clips["slow_walk"]
    durations = np.full(walk.num_frames, 1 / 30)
    durations[5] = 1e-7
    lib = motion.build_motion_lib([_nonuniform(walk, rng, durations)], character)
    assert lib.grid_size[0] <= motion.MAX_CELLS_PER_FRAME * walk.num_frames
    step = lib.grid_step[0]
    tau = _hard_times(lib, 0, rng, count=2000)
    got, ref = _lookup(lib, 0, tau), _brute_force_frame(lib, 0, tau)
    near = np.abs(tau - lib.times[6]) <= 2 * step  # the one place where a cell holds two frame times
    np.testing.assert_array_equal(got[~near], ref[~near])
    assert np.all(got[near] <= ref[near])
    assert np.all(got[near] >= _brute_force_frame(lib, 0, tau[near] - step))


def test_two_clip_library_samples_each_clips_frames(project_clips, character):
    clips = [project_clips["slow_walk"], project_clips["squat"]]
    lib = motion.build_motion_lib(clips, character)
    for c, clip in enumerate(clips):
        assert lib.duration[c] == pytest.approx(clip.duration)
        for f in range(clip.num_frames - 1):  # the last frame of a cyclic clip starts the next cycle
            qpos, _ = motion.sample(lib, c, np.float32(clip.frame_times[f]))
            np.testing.assert_allclose(qpos, clip.qpos[f], atol=1e-5)
        alone = motion.build_motion_lib([clip], character)
        for t in (0.13, 1.1, 2.7):
            for a, b in zip(motion.sample(lib, c, np.float32(t)), motion.sample(alone, 0, np.float32(t))):
                np.testing.assert_allclose(a, b, atol=1e-6)


def _knee_wave(character, base, loop):
    """`base`'s first pose with the right knee swinging as a sine, 30 frames a second for one 1 s
    cycle: a smooth motion whose velocity is known. (clip, knee's qvel index, its speed at t)"""
    joint = character.model.joint("right_knee")
    t = np.arange(31) / 30.0
    qpos = np.repeat(base.qpos[:1], len(t), axis=0)
    qpos[:, joint.qposadr[0]] = -1.0 + 0.8 * np.sin(2 * np.pi * t)
    clip = Clip(name="knee_wave", path=None, loop=loop, durations=np.full(len(t), 1 / 30.0), qpos=qpos)
    return clip, int(joint.dofadr[0]), lambda s: 0.8 * 2 * np.pi * np.cos(2 * np.pi * s)


@pytest.mark.parametrize("loop", [True, False])
def test_central_velocities_do_not_lead_the_pose(project_clips, character, loop):
    """Blended forward differences lead a smooth motion by half a frame; central ones track it."""
    clip, dof, speed = _knee_wave(character, project_clips["slow_walk"], loop)
    errors = {}
    for velocity in ("forward", "central"):
        lib = motion.build_motion_lib([clip], character, velocity=velocity)
        times = np.linspace(0.0, 0.99, 100) if loop else np.linspace(0.04, 0.95, 100)  # not the ends
        errors[velocity] = max(abs(motion.sample(lib, 0, np.float32(s))[1][dof] - speed(s)) for s in times)
        for f in (0, 7, 29):  # frames and poses are the same either way
            np.testing.assert_allclose(motion.sample(lib, 0, np.float32(f / 30.0))[0], clip.qpos[f], atol=1e-5)
    peak = 0.8 * 2 * np.pi
    assert errors["forward"] > 0.08 * peak  # about half a frame's change of a 5 rad/s swing
    assert errors["central"] < 0.2 * errors["forward"]


def test_the_config_key_picks_the_reference_velocity(project_clips, character):
    from mjxmimic.core.config import make_config
    from mjxmimic.envs.step import build

    with pytest.raises(UserError, match="clip.velocity"):
        make_config("cpu", {"clip.velocity": "spline"})
    clips = [project_clips["slow_walk"]]
    built = {}
    for velocity in ("forward", "central"):
        _, spec = build(make_config("cpu", {"clip.velocity": velocity}), character, clips, np)
        built[velocity] = spec.lib.qvel
        np.testing.assert_array_equal(built[velocity], motion.build_motion_lib(clips, character, velocity=velocity).qvel)
    assert not np.allclose(built["forward"], built["central"])


def test_draw_clip_follows_the_weights(project_clips, character):
    clips = [project_clips[n] for n in ("slow_walk", "squat", "wave", "squat")]
    weights = np.array([1.0, 3.0, 0.0, 2.0])
    lib = motion.build_motion_lib(clips, character, weights=weights)
    np.testing.assert_allclose(lib.clip_weight, weights / 6, rtol=1e-6)
    n = 200_000
    drawn = motion.draw_clip(lib, np.random.default_rng(3).random(n))
    share = np.bincount(drawn, minlength=4) / n
    np.testing.assert_allclose(share, weights / 6, atol=0.005)  # 5 standard errors; a 1/6 slip fails
    assert motion.draw_clip(lib, 0.0) == 0
    assert motion.draw_clip(lib, np.float32(np.nextafter(np.float32(1), np.float32(0)))) == 3
    assert motion.draw_clip(lib, 1.0 - 1e-12) == 3  # never the 0-weight clip, never past the end
    uniform = motion.build_motion_lib(clips[:2], character)
    np.testing.assert_allclose(uniform.clip_weight, [0.5, 0.5])


@pytest.mark.parametrize("weights, message", [
    ([1.0], "one weight per clip"),
    ([1.0, -1.0], ">= 0"),
    ([1.0, np.nan], "finite"),
    ([0.0, 0.0], "all 0"),
])
def test_bad_weights_are_user_errors(project_clips, character, weights, message):
    clips = [project_clips["slow_walk"], project_clips["squat"]]
    with pytest.raises(UserError, match=message) as err:
        motion.build_motion_lib(clips, character, weights=weights)
    assert "\n" not in str(err.value)


def test_jax_matches_numpy_under_jit_and_vmap(project_clips, character):
    jax = pytest.importorskip("jax")
    jnp = jax.numpy
    rng = np.random.default_rng(4)
    clips = list(project_clips.values()) + [_nonuniform(project_clips["squat"], rng)]
    lib = motion.build_motion_lib(clips, character, weights=[1, 2, 3, 4])
    jlib = jax.tree.map(jnp.asarray, lib)
    n = 256
    u = rng.random(n).astype(np.float32)
    t = rng.uniform(0, 3 * lib.duration.max(), n).astype(np.float32)

    @jax.jit
    @jax.vmap
    def run(u, t):
        c = motion.draw_clip(jlib, u, jnp)
        dur = jlib.duration[c]
        tau = jnp.clip(t - jnp.floor(t / dur) * dur, 0.0, dur)
        return (c, motion._frame_index(jlib, c, tau, jnp)) + motion.sample(jlib, c, t, jnp)

    clip_j, frame_j, qpos_j, qvel_j = (np.asarray(a) for a in run(u, t))
    for i in range(n):
        c = motion.draw_clip(lib, u[i])
        assert clip_j[i] == c
        dur = lib.duration[c]
        tau = np.clip(t[i] - np.floor(t[i] / dur) * dur, np.float32(0), dur)
        assert frame_j[i] == _brute_force_frame(lib, c, tau)[0]
        qpos, qvel = motion.sample(lib, c, t[i])
        np.testing.assert_allclose(qpos_j[i], qpos, atol=1e-4)
        np.testing.assert_allclose(qvel_j[i], qvel, atol=1e-3)
