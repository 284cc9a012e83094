"""The throw task (mjxmimic.task.goals): the authored pitch clip, the ball held in the hand and let
go at the release time, the target on the floor, landing, hits and misses, MJX and MuJoCo C alike."""

import dataclasses
import importlib.util
import math

import numpy as np
import pytest

from mjxmimic.core.config import make_config
from mjxmimic.core.errors import UserError
from mjxmimic.task import goals

THROW = make_config("cpu", {"task.name": "throw", "env.action_mode": "residual", "env.episode_seconds": 3.0})


@pytest.fixture(scope="module")
def pitch(character):
    from mjxmimic.motion.clip import load_clip_source

    return load_clip_source("pitch", character)


@pytest.fixture(scope="module")
def throw_env(character, pitch):
    from mjxmimic.envs.cpu_env import CpuEnv

    return CpuEnv(THROW, character, pitch)


def _ball(env):
    return env.data.qpos[-7:-4].copy(), env.data.qvel[-6:-3].copy()


def _hand_point(env):
    """Where the hand holds the ball in the present pose."""
    k = env.physics.kinematics(env.data.qpos, env.data.qvel)
    return goals.ball_in_hand(k, env.spec.task_body, np)[0][:3]


def test_pitch_clip_is_a_throw_released_at_its_release_time(character, pitch):
    from mjxmimic.motion import library as motion_lib
    from mjxmimic.motion.clip import lowest_points
    from mjxmimic.motion.clips import make_clips

    assert not pitch.loop and pitch.duration == pytest.approx(make_clips.PITCH_S, abs=1e-6)
    assert THROW.task.release_s == make_clips.PITCH_RELEASE_S  # the config's default is the clip's
    assert np.all(np.abs(lowest_points(character, pitch.qpos)) < 0.01)  # on the floor, nothing below it
    # The reference hand is fastest around the release and moves forward (+x) and a little up then:
    # let go there, the ball flies about 5 m.
    lib = motion_lib.build_motion_lib([pitch], character)
    from mjxmimic.physics.cpu import CpuPhysics
    from mjxmimic.core.layout import make_layout
    from mjxmimic.core.scene import build_scene

    physics = CpuPhysics(build_scene(character, 120, 4, 4), make_layout(character), 4, "total")
    hand = character.model.body("right_wrist").id

    def ball_at(t):
        k = physics.kinematics(*motion_lib.sample(lib, 0, np.float32(t), np))
        return goals.ball_in_hand(k, hand, np)

    times = np.arange(0.0, pitch.duration, 1 / 30)
    positions = np.array([ball_at(t)[0][:3] for t in times])
    speeds = np.linalg.norm(np.gradient(positions, 1 / 30, axis=0), axis=1)  # frame to frame, centred
    release = int(round(make_clips.PITCH_RELEASE_S * 30))
    v = (positions[release + 1] - positions[release - 1]) * 15.0
    assert abs(np.argmax(speeds) - release) <= 1
    assert v[0] > 5.0 and v[2] > 0.0 and abs(v[1]) < 0.3 * v[0]
    assert 3.0 < goals.landing_point(positions[release], v, 0.037, np)[0] < 7.0


def test_the_ball_comes_after_the_character_and_only_the_goal_grows(character, pitch, throw_env):
    from mjxmimic.envs.cpu_env import CpuEnv

    plain = CpuEnv(make_config("cpu", {"env.action_mode": "residual", "clip.name": "pitch"}), character, pitch)
    assert throw_env.model.nq == character.nq + 7 and throw_env.model.nv == character.nv + 6
    assert throw_env.model.nbody == character.model.nbody + 1 and plain.model.nq == character.nq
    assert throw_env.action_size == plain.action_size == character.action_size
    assert throw_env.observation_size == plain.observation_size + goals.GOAL_SIZE["throw"] == plain.observation_size + 11
    assert len(throw_env.scene.contact_adr) == len(plain.scene.contact_adr)  # the ball is never a fall
    obs_plain, obs = plain.reset_at(0.5), throw_env.reset_at(0.5)
    np.testing.assert_allclose(obs[: plain.observation_size], obs_plain, atol=1e-6)


def test_config_defaults_and_one_line_errors(character, pitch):
    from mjxmimic.envs.cpu_env import CpuEnv

    assert (THROW.clip.name, THROW.task.target_min_m, THROW.task.target_max_m) == ("pitch", 3.0, 6.0)
    mine = make_config("cpu", {"task.name": "throw", "task.target_max_m": 9.0, "clip.name": "wave"})
    assert (mine.clip.name, mine.task.target_min_m, mine.task.target_max_m) == ("wave", 3.0, 9.0)
    with pytest.raises(UserError, match="task.release_s"):
        make_config("cpu", {"task.name": "throw", "task.release_s": 0})
    with pytest.raises(UserError, match="task.throw_shape"):
        make_config("cpu", {"task.name": "throw", "task.throw_shape": 0})
    with pytest.raises(UserError, match="task.target_min_m"):
        make_config("cpu", {"task.name": "throw", "task.target_max_m": 1.0})
    for overrides, match in [({"task.throw_hand": "tail"}, "task.throw_hand.*no body 'tail'"),
                             ({"task.release_s": 3.0}, "task.release_s.*before the end of clip 'pitch'")]:
        with pytest.raises(UserError, match=match) as err:
            CpuEnv(make_config("cpu", {"task.name": "throw", **overrides}), character, pitch)
        assert "\n" not in str(err.value)


def test_target_is_on_the_floor_around_the_character_and_the_same_in_jax(throw_env):
    import jax.numpy as jnp

    from mjxmimic.envs import step as step_lib

    distances, angles = [], []
    for seed in np.linspace(0, 1, 32, endpoint=False):
        obs = throw_env.reset_at(0.3, event_seed=seed)
        goal, root = throw_env.motion.goal, throw_env.data.qpos[:2]
        distances.append(np.hypot(*(goal[:2] - root)))
        angles.append(math.atan2(goal[1] - root[1], goal[0] - root[0]))
        assert goal[2] == 0.0 and goal[3] == pytest.approx(distances[-1], abs=1e-5)
        assert obs[-2:].tolist() == [0.0, 0.0]  # held, not landed
        assert np.hypot(*obs[-11:-9]) == pytest.approx(distances[-1], abs=0.05)  # heading frame, from the root
        in_jax = step_lib.initial_goal(throw_env.spec, jnp.asarray(throw_env.data.qpos, jnp.float32),
                                       jnp.float32(seed), jnp)
        np.testing.assert_allclose(np.asarray(in_jax), goal, atol=1e-5)
    assert 3.0 - 1e-4 <= min(distances) and max(distances) <= 6.0 + 1e-4
    assert np.histogram(angles, bins=4, range=(-math.pi, math.pi))[0].min() >= 4  # all around


def test_the_hand_holds_the_ball_until_the_release_then_it_flies_and_lands(throw_env):
    env = throw_env
    release = env.config.task.release_s
    env.reset_at(0.6, event_seed=0.1)
    np.testing.assert_allclose(_ball(env)[0], _hand_point(env), atol=1e-9)
    zero = np.zeros(env.action_size)
    dt, g = env.control_dt, goals.GRAVITY
    flight = []
    for _ in range(int(round((env.clip_duration - 0.6) / dt)) - 1):
        s = env.step(zero)
        if env.time < release - 1e-6:
            np.testing.assert_allclose(_ball(env)[0], _hand_point(env), atol=1e-9)  # in the hand
            assert s.obs[-2] == 0.0
        else:
            assert s.obs[-2] == 1.0  # let go
            flight.append((_ball(env), env.motion.goal.copy(), s.metrics))
        if s.done:
            break
    # free flight: the hand lets go, gravity alone acts until the ball comes down
    (p0, v0), _, m0 = flight[0]
    (p1, v1), _, _ = flight[1]
    np.testing.assert_allclose(v1[:2], v0[:2], atol=1e-6)
    assert v1[2] - v0[2] == pytest.approx(-g * dt, rel=1e-3)
    landed = [k for k, (_, goal, _) in enumerate(flight) if goal[2] > 0]
    assert landed, "the ball never landed"
    k = landed[0]
    (pk, _), goal, m = flight[k]
    assert pk[2] <= 0.037 + goals.LAND_TOLERANCE_M
    # where it landed is the ballistic landing point predicted from the step before
    (pb, vb), _, _ = flight[k - 1]
    predicted = goals.landing_point(pb, vb, 0.037, np)
    assert goal[3] == pytest.approx(np.hypot(*(predicted - goal[:2])), abs=1e-5)
    assert np.hypot(*(pk[:2] - predicted)) < 0.15
    assert m["task/distance"] == pytest.approx(goal[3], abs=1e-6)


@pytest.mark.parametrize("offset, hit, shape", [(0.0, True, 0.5), (0.3, True, 0.5), (1.5, False, 0.5), (1.5, False, 4.0)])
def test_a_ball_dropped_on_the_target_is_a_hit_and_elsewhere_a_miss(throw_env, character, pitch, offset, hit, shape):
    from mjxmimic.envs.cpu_env import CpuEnv

    env = throw_env if shape == THROW.task.throw_shape else CpuEnv(
        dataclasses.replace(THROW, task=dataclasses.replace(THROW.task, throw_shape=shape)), character, pitch)
    env.reset_at(env.config.task.release_s + 0.05, event_seed=0.7)  # already let go
    goal = env.motion.goal
    qpos, qvel = env.data.qpos.copy(), env.data.qvel.copy()
    qpos[-7:] = [goal[0] + offset, goal[1], 1.0, 1.0, 0.0, 0.0, 0.0]  # 1 m above the target
    qvel[-6:] = 0.0
    env.physics.with_qpos_qvel(env.data, qpos, qvel)
    zero = np.zeros(env.action_size)
    hits, rewards = [], []
    for _ in range(20):  # 0.45 s to fall 1 m
        s = env.step(zero)
        hits.append(s.metrics["task/hit"])
        rewards.append(s.metrics["reward/task"])
    assert env.motion.goal[2] == 1.0  # landed
    assert env.motion.goal[3] == pytest.approx(offset, abs=0.02)
    assert (hits[-1] == 1.0) == hit and hits[-1] == hits[-2]  # stays recorded
    radius = env.config.task.target_radius_m
    assert rewards[-1] == pytest.approx(math.exp(-env.config.task.throw_shape * max(0.0, offset - radius) ** 2), abs=0.02)


def test_a_ball_launched_at_the_target_lands_on_it():
    """The pure step rule: a ballistic flight from the hand onto the target counts as a hit."""
    task = THROW.task
    target = np.array([4.0, 1.0])
    pos, vel = np.array([0.0, 0.0, 1.6]), np.array([0.0, 0.0, 2.0])
    fall = (2.0 + math.sqrt(4.0 + 2 * goals.GRAVITY * (1.6 - 0.037))) / goals.GRAVITY
    vel[:2] = target / fall
    goal = np.array([*target, 0.0, 4.0], np.float32)
    dt, landed_at = 1 / 30, None
    for k in range(60):
        r, goal, d, hit = goals.throw(task, pos, vel, True, 0.037, goal, np)
        if goal[2] > 0 and landed_at is None:
            landed_at = k
        pos = pos + vel * dt + [0.0, 0.0, -0.5 * goals.GRAVITY * dt * dt]
        vel = vel + [0.0, 0.0, -goals.GRAVITY * dt]
        pos[2] = max(pos[2], 0.037)  # the floor
    assert landed_at is not None and hit and d < 1e-3 and r == 1.0
    miss = np.array([*(target + [2.0, 0.0]), 0.0, 4.0], np.float32)
    r, _, d, hit = goals.throw(task, np.array([0.0, 0.0, 1.6]), np.array([*(target / fall), 2.0]), True, 0.037,
                               miss, np)
    assert not hit and d == pytest.approx(2.0, abs=1e-4) and r == pytest.approx(math.exp(-0.5 * 1.5**2))


def test_throw_success_is_a_landing_on_the_target():
    acc = {"reward/task": np.array([3.0, 1.0]), "task/hit": np.array([0.0, 4.0]), "task/distance": np.ones(2)}
    out = goals.metrics_summarize("throw", acc, np.array([10, 10]), np.array([False, False]))
    assert out["success_rate"] == 0.5 and out["task_return"] == pytest.approx(0.2)


def test_videos_draw_the_target_and_the_ball(throw_env):
    from mjxmimic.portable.render import Scene, goal_markers, setup_gl

    try:
        setup_gl()
    except UserError as err:
        pytest.skip(f"no headless OpenGL: {err}")
    env = throw_env
    env.reset_at(0.3, event_seed=0.0)
    markers = goal_markers(env)
    assert len(markers) == 2 and len(goal_markers(env, ball=False)) == 1
    scene = Scene(env.character.xml_path, env.character.nq, ghost=False, width=160, height=128)
    try:
        plain = scene.frame(env.data.qpos).astype(int)
        drawn = scene.frame(env.data.qpos, markers=markers).astype(int)
    finally:
        scene.close()
    assert (np.abs(drawn - plain).sum(axis=-1) > 30).sum() > 5


@pytest.mark.slow
def test_mjx_and_mujoco_c_carry_and_throw_the_ball_alike(character, pitch, throw_env):
    """The same start and actions on MJX-JAX and MuJoCo C: the ball in the hand, let go, in flight,
    at the same places (a converged solve, so the two solvers agree)."""
    import jax
    import jax.numpy as jnp

    from mjxmimic.core.config import apply_overrides
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.envs.mjx_env import ImitationEnv

    config = apply_overrides(THROW, {"physics.backend": "jax", "env.solver_iterations": 30,
                                     "env.ls_iterations": 30})
    env = ImitationEnv(config, character, [pitch])
    cpu = CpuEnv(config, character, pitch)
    t0, seed = 0.9, 0.25
    state = jax.jit(env.reset_at)(jax.random.PRNGKey(0), t0)
    seed = float(state.info["event_seed"])
    cpu.reset_at(t0, event_seed=seed)
    np.testing.assert_allclose(np.asarray(state.info["goal"]), cpu.motion.goal, atol=1e-4)
    np.testing.assert_allclose(np.asarray(state.pipeline_state.qpos), cpu.data.qpos, atol=1e-5)
    transition = jax.jit(env.transition)
    actions = np.random.default_rng(0).uniform(-0.1, 0.1, (12, env.action_size)).astype(np.float32)
    for a in actions:  # 0.4 s: from before the release (1.1 s) well into the flight
        state = transition(state, jnp.asarray(a))
        cpu.step(a)
        np.testing.assert_allclose(np.asarray(state.pipeline_state.qpos)[-7:-4], cpu.data.qpos[-7:-4], atol=2e-3)
        np.testing.assert_allclose(np.asarray(state.obs)[-11:], cpu._observe(cpu.motion)[-11:], atol=2e-2)
    assert float(state.obs[-2]) == 1.0  # let go on both


def test_every_episode_starts_before_the_release(throw_env):
    from mjxmimic.envs import starts

    release = throw_env.config.task.release_s
    assert float(starts.start_time_range(throw_env.spec, 0, np)) == pytest.approx(release)
    assert float(throw_env.eval_start_limits[0]) == pytest.approx(release)
    assert 0.9 * release < throw_env.start_times(64, 0).max() < release


def test_pushes_and_external_forces_still_reach_the_character(character, pitch):
    """Pushes are (character bodies, 6), a push test's force the scene's (with the ball's row)."""
    from mjxmimic.envs.cpu_env import CpuEnv

    config = make_config("cpu", {"task.name": "throw", "env.events": "push", "env.push_force_n": 300.0,
                                 "env.push_interval_s": 0.2, "env.push_duration_s": 0.1})
    env = CpuEnv(config, character, pitch)
    calm = CpuEnv(make_config("cpu", {"task.name": "throw"}), character, pitch)
    zero = np.zeros(env.action_size)
    for e in (env, calm):
        e.reset_at(0.2)
        for _ in range(9):
            e.step(zero, external_force=np.zeros((e.model.nbody, 6)))
    assert np.abs(env.data.qvel[:2] - calm.data.qvel[:2]).max() > 0.1  # pushed


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("warp") is None, reason="warp-lang not installed")
def test_warp_carries_the_ball_and_lets_it_fly(character, pitch):
    """MJX-Warp (here on the CPU): the ball sits at the hand while held, then only gravity acts."""
    import jax
    import jax.numpy as jnp

    from mjxmimic.core.config import apply_overrides
    from mjxmimic.envs.mjx_env import ImitationEnv

    env = ImitationEnv(apply_overrides(THROW, {"physics.backend": "warp"}), character, [pitch], max_worlds=1)
    state = jax.jit(env.reset_at)(jax.random.PRNGKey(0), 0.9)
    transition, kinematics = jax.jit(env.transition), jax.jit(env.physics.kinematics)
    velocities = []
    for _ in range(12):
        state = transition(state, jnp.zeros(env.action_size))
        q, v = state.pipeline_state.qpos, state.pipeline_state.qvel
        if float(state.info["time"]) < THROW.task.release_s - 1e-4:
            hand = goals.ball_in_hand(kinematics(q, v), env.spec.task_body, jnp)[0][:3]
            np.testing.assert_allclose(np.asarray(q[-7:-4]), np.asarray(hand), atol=1e-6)
        else:
            velocities.append(np.asarray(v[-6:-3]))
    dv = np.diff(np.array(velocities), axis=0)
    np.testing.assert_allclose(dv, np.tile([0.0, 0.0, -goals.GRAVITY * env.control_dt], (len(dv), 1)), atol=1e-4)
