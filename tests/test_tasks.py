"""The target-heading task (mjxmimic.task.goals): its goals, reward, observation, the reference that
turns with the character, and the task metrics of an evaluation."""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjxmimic.core import quat
from mjxmimic.core.config import make_config
from mjxmimic.core.errors import UserError
from mjxmimic.task import goals

HEADING = make_config("cpu", {"task.name": "heading", "env.action_mode": "residual", "task.resample_s": 2.0})


@pytest.fixture(scope="module")
def cpu_env(character):
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source

    return CpuEnv(HEADING, character, load_clip_source("slow_walk", character))


def test_goals_change_every_resample_interval_and_spread_over_episodes(cpu_env):
    lib = cpu_env.spec.lib
    yaw = lambda t, seed: float(goals.heading_goal(HEADING.task, lib, 0, t, seed, np)[0])  # noqa: E731
    assert yaw(0.0, 0.3) == yaw(1.99, 0.3) != yaw(2.0, 0.3)  # one direction per 2 s
    assert yaw(0.5, 0.3) != yaw(0.5, 0.6)  # episodes differ by their seed
    first = np.array([yaw(0.0, s) for s in np.linspace(0, 1, 64, endpoint=False)])
    counts = np.histogram(first, bins=4, range=(0, 2 * math.pi))[0]
    assert counts.min() >= 8  # spread around the circle
    speed = float(goals.heading_goal(HEADING.task, lib, 0, 0.0, 0.3, np)[1])
    shift = lib.cycle_shift[0]
    assert speed == pytest.approx(np.hypot(*shift) / lib.duration[0], rel=1e-5)  # auto: the clip's own
    fixed = make_config("cpu", {"task.name": "heading", "task.speed": 1.5}).task
    assert float(goals.heading_goal(fixed, lib, 0, 0.0, 0.3, np)[1]) == pytest.approx(1.5)


def test_heading_reward_does_not_punish_speeding():
    assert goals.heading_reward(1.0, 1.0, np) == pytest.approx(1.0)
    assert goals.heading_reward(2.0, 1.0, np) == pytest.approx(1.0)
    assert goals.heading_reward(0.8, 1.0, np) == pytest.approx(math.exp(-2.5 * 0.04))
    assert goals.heading_reward(-1.0, 1.0, np) == pytest.approx(math.exp(-10.0))


def test_goal_is_observed_in_the_heading_frame(cpu_env):
    obs = cpu_env.reset_at(0.4, event_seed=0.25)
    yaw, speed = goals.heading_goal(HEADING.task, cpu_env.spec.lib, 0, 0.0, 0.25, np)
    facing = quat.heading(cpu_env.data.qpos[3:7].copy())
    assert obs.shape == (cpu_env.spec.observation_size,)
    np.testing.assert_allclose(obs[-3:], [math.cos(yaw - facing), math.sin(yaw - facing), speed], atol=1e-5)


def test_imitation_grades_the_pose_whichever_way_the_character_faces(cpu_env):
    """The reference turns with the character: a reference state turned by 90 degrees and moved
    away scores the imitation reward of the unturned one; without a task it would not."""
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion import library as motion_lib

    plain = CpuEnv(make_config("cpu", {"env.action_mode": "residual"}), cpu_env.character, cpu_env.clip)
    qpos, qvel = motion_lib.sample(cpu_env.spec.lib, 0, np.float32(0.4), np)
    turned_q, turned_v = qpos.copy(), qvel.copy()
    turn = quat.from_yaw(np.asarray(0.5 * math.pi))
    turned_q[3:7] = quat.mul(turn, qpos[3:7])
    turned_q[0:2] += [3.0, -2.0]
    turned_v[0:3] = quat.rotate_yaw(qvel[0:3], np.asarray(0.5 * math.pi))
    zero = np.zeros(cpu_env.character.action_size)
    rewards = {}
    for name, env in (("task", cpu_env), ("plain", plain)):
        for label, (q, v) in (("straight", (qpos, qvel)), ("turned", (turned_q, turned_v))):
            env.set_state(q, v, 0.4)
            rewards[name, label] = env.step(zero).metrics["reward/imitation"]
    assert rewards["task", "turned"] == pytest.approx(rewards["task", "straight"], abs=1e-3)
    assert rewards["task", "straight"] == pytest.approx(rewards["plain", "straight"], abs=1e-3)
    assert rewards["plain", "turned"] < rewards["plain", "straight"] - 0.2


def test_training_reward_mixes_imitation_and_task(cpu_env):
    cpu_env.reset_at(0.2, event_seed=0.1)
    m = cpu_env.step(np.zeros(cpu_env.character.action_size)).metrics
    assert m["reward"] == pytest.approx(0.7 * m["reward/imitation"] + 0.3 * m["reward/task"], rel=1e-5)
    assert m["reward/task"] == pytest.approx(float(goals.heading_reward(m["task/speed_along"], m["task/speed"], np)))


def test_cpu_evaluation_reports_task_metrics(cpu_env):
    from mjxmimic.portable.playback import evaluate

    out = evaluate(cpu_env, lambda obs: np.zeros(cpu_env.character.action_size), [0.1, 0.5, 0.9])
    assert {"task_return", "speed_ratio", "success_rate"} <= set(out)
    assert 0.0 <= out["task_return"] <= 1.0 and 0.0 <= out["success_rate"] <= 1.0
    assert out["task_return"] < out["nr"]  # standing still does not reach a walking goal


def test_success_counts_speed_within_tolerance_and_no_fall():
    acc = {"task_reward": np.array([10.0, 10.0, 10.0]), "speed_along": np.array([9.0, 5.0, 10.0]),
           "speed": np.array([10.0, 10.0, 10.0])}
    acc = {"reward/task": acc["task_reward"], "task/speed_along": acc["speed_along"], "task/speed": acc["speed"]}
    out = goals.metrics_summarize("heading", acc, np.array([20, 20, 20]), np.array([False, False, True]))
    assert out["success_rate"] == pytest.approx(1 / 3) and out["task_return"] == pytest.approx(0.5)
    assert out["speed_ratio"] == pytest.approx(0.8)


def test_task_config_errors():
    with pytest.raises(UserError, match="task.name"):
        make_config("cpu", {"task.name": "juggle"})
    with pytest.raises(UserError, match="task.resample_s"):
        make_config("cpu", {"task.resample_s": 0})


@pytest.mark.slow
@pytest.mark.parametrize("task, size", [("heading", 3), ("strike", 4), ("throw", 11)])
def test_mjx_env_appends_the_goal_and_evaluates_the_task(character, task, size):
    import jax
    import jax.numpy as jnp

    from mjxmimic.envs.mjx_env import ImitationEnv
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.runs.evaluate import evaluate

    config = make_config("cpu", {"task.name": task, "env.action_mode": "residual", "physics.backend": "jax",
                                 "run.eval_episodes": 2})
    env = ImitationEnv(config, character, [load_clip_source(config.clip.name, character)])
    plain = make_config("cpu", {"env.action_mode": "residual"})
    assert env.observation_size == ImitationEnv(plain, character, env.clips).observation_size + size
    out = evaluate(env, lambda obs, key: jnp.zeros(obs.shape[:-1] + (env.action_size,)), config, seed=0)
    assert {"task_return", "success_rate", "nr", "nr_paper"} <= set(out)
    assert 0.0 <= out["task_return"] < out["nr"] <= 1.0
    state = jax.jit(env.reset_at)(jax.random.PRNGKey(0), 0.3)
    assert np.isfinite(np.asarray(state.obs)).all()


def test_heading_goal_is_drawn_as_a_green_arrow(cpu_env):
    from mjxmimic.portable.render import GOAL_RGBA, Scene, goal_arrow, setup_gl

    try:
        setup_gl()
    except UserError as err:
        pytest.skip(f"no headless OpenGL: {err}")
    cpu_env.reset_at(0.3, event_seed=0.4)
    tail, head, rgba = goal_arrow(cpu_env)
    yaw, speed = goals.heading_goal(HEADING.task, cpu_env.spec.lib, 0, 0.0, 0.4, np)
    np.testing.assert_allclose(head - tail, [speed * math.cos(yaw), speed * math.sin(yaw), 0.0], atol=1e-6)
    scene = Scene(cpu_env.character.xml_path, cpu_env.character.nq, ghost=False, width=160, height=128)
    try:
        plain = scene.frame(cpu_env.data.qpos).astype(int)
        drawn = scene.frame(cpu_env.data.qpos, arrows=[(tail, head, rgba)]).astype(int)
    finally:
        scene.close()
    changed = np.abs(drawn - plain).sum(axis=-1) > 30
    assert changed.sum() > 20 and np.mean(drawn[changed][:, 1] > drawn[changed][:, 0] + 30) > 0.5  # green
    assert rgba == GOAL_RGBA


STRIKE = make_config("cpu", {"task.name": "strike", "env.action_mode": "residual", "task.target_min_m": 0.6,
                             "task.target_max_m": 0.9})


@pytest.fixture(scope="module")
def strike_env(character):
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source

    return CpuEnv(STRIKE, character, load_clip_source("slow_walk", character))


def test_strike_target_is_placed_around_the_character(strike_env):
    distances, angles = [], []
    for seed in np.linspace(0, 1, 32, endpoint=False):
        obs = strike_env.reset_at(0.3, event_seed=seed)
        target = strike_env.motion.goal
        root = strike_env.data.qpos[:2]
        distances.append(np.hypot(*(target[:2] - root)))
        angles.append(math.atan2(*(target[1::-1] - root[::-1])))
        assert target[2] == pytest.approx(1.2) and target[3] == 0.0
        assert obs.shape == (strike_env.spec.observation_size,) and obs[-1] == 0.0  # not hit yet
        assert np.linalg.norm(obs[-4:-2]) == pytest.approx(distances[-1], abs=0.05)  # heading frame, from the root
    assert 0.6 - 1e-4 <= min(distances) and max(distances) <= 0.9 + 1e-4
    assert np.histogram(angles, bins=4, range=(-math.pi, math.pi))[0].min() >= 4  # all around


def test_a_hit_pays_one_and_stays_recorded(strike_env):
    strike_env.reset_at(0.3, event_seed=0.2)
    zero = np.zeros(strike_env.character.action_size)
    far = strike_env.step(zero).metrics
    assert far["task/hit"] == 0.0 and far["reward/task"] == pytest.approx(math.exp(-4 * far["task/distance"] ** 2))
    # put the target on the striking foot: the next step hits
    foot = strike_env.spec.task_body
    goal = strike_env.motion.goal.copy()
    goal[:3] = strike_env.data.xipos[foot]
    strike_env.motion = strike_env.motion._replace(goal=goal)
    hit = strike_env.step(zero).metrics
    assert hit["task/hit"] == 1.0 and hit["reward/task"] == 1.0
    # moved away again, the target stays hit for the rest of the episode
    goal = strike_env.motion.goal.copy()
    goal[:3] += [5.0, 0.0, 0.0]
    strike_env.motion = strike_env.motion._replace(goal=goal)
    after = strike_env.step(zero).metrics
    assert after["task/hit"] == 1.0 and after["reward/task"] == 1.0 and after["task/distance"] > 4.0


def test_each_cycle_of_the_clip_brings_a_new_target(character):
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source

    each_cycle = dataclasses.replace(STRIKE.task, target_each_cycle=True)
    clip = load_clip_source("slow_walk", character)
    env = CpuEnv(dataclasses.replace(STRIKE, task=each_cycle), character, clip)
    duration = float(env.clip_durations[0])
    zero = np.zeros(env.character.action_size)
    env.reset_at(duration - 1.5 * env.control_dt, event_seed=0.3)
    first = env.motion.goal.copy()
    hit_already = np.concatenate([first[:3], [1.0]]).astype(np.float32)
    env.motion = env.motion._replace(goal=hit_already)
    same = env.step(zero).metrics  # still in the first cycle
    assert same["task/new_target"] == 0.0 and same["task/new_hit"] == 0.0 and env.motion.goal[3] == 1.0
    crossed = env.step(zero).metrics  # into the second cycle
    goal = env.motion.goal
    assert crossed["task/new_target"] == 1.0 and crossed["task/hit"] == 1.0  # the old target's flag
    assert goal[3] == 0.0 and not np.allclose(goal[:2], first[:2])
    assert 0.6 - 1e-3 <= np.hypot(*(goal[:2] - env.data.qpos[:2])) <= 0.9 + 1e-3
    assert goal[2] == pytest.approx(1.2)
    assert env.step(zero).metrics["task/new_target"] == 0.0 and np.array_equal(env.motion.goal, goal)
    # the same rule traced by JAX (the MJX env's step)
    lib = env.spec.lib
    renew = jax.jit(lambda a, b: goals.renew_target(each_cycle, lib, 0, a, b, jnp.zeros(7), 0.3,
                                                    jnp.asarray(first), jnp))
    kept, fresh = renew(0.1, 0.2), renew(duration - 0.01, duration + 0.02)
    assert not kept[1] and np.array_equal(kept[0], first) and fresh[1] and fresh[0][3] == 0.0
    # the reset's target had only part of cycle 0; the one placed at cycle 1's start had all of it
    later = renew(2 * duration - 0.01, 2 * duration + 0.02)
    assert not kept[2] and not fresh[2] and later[1] and later[2]
    once = CpuEnv(STRIKE, character, clip)
    once.reset_at(duration - 1.5 * once.control_dt, event_seed=0.3)
    start = once.motion.goal.copy()
    assert sum(once.step(zero).metrics["task/new_target"] for _ in range(3)) == 0.0
    assert np.array_equal(once.motion.goal, start)


def test_strike_success_is_the_share_of_targets_hit_and_bad_body_is_one_line(character):
    acc = {"reward/task": np.array([3.0, 1.0]), "task/hit": np.array([2.0, 0.0]), "task/distance": np.ones(2),
           "task/new_hit": np.array([1.0, 0.0]), "task/new_target": np.zeros(2),
           "task/whole_cycle_hit": np.zeros(2)}
    out = goals.metrics_summarize("strike", acc, np.array([10, 10]), np.array([False, True]))
    assert out["success_rate"] == 0.5 and out["task_return"] == pytest.approx(0.2)
    assert "whole_cycle_success_rate" not in out
    # a new target each cycle: 2 + 6 targets shown, 4 hit; of the 4 shown for a whole cycle, 3 hit
    acc.update({"task/new_hit": np.array([3.0, 1.0]), "task/new_target": np.array([4.0, 2.0]),
                "task/whole_cycle_hit": np.array([2.0, 1.0])})
    out = goals.metrics_summarize("strike", acc, np.array([10, 10]), np.array([False, True]))
    assert out["success_rate"] == 0.5 and out["targets_per_episode"] == 4.0
    assert out["whole_cycle_success_rate"] == 0.75
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source

    bad = make_config("cpu", {"task.name": "strike", "task.strike_body": "tail"})
    with pytest.raises(UserError, match="no body 'tail'"):
        CpuEnv(bad, character, load_clip_source("slow_walk", character))
