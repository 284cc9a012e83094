"""Training with pushes and domain randomisation (issue 17): the new keys' validation, random push
forces and start times, the per-episode friction and mass factors (in range, different between
episodes, the same bits on numpy and JAX), the physics they change, MJX-CPU parity, and off by
default."""

import importlib.util

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjxmimic.core.config import apply_overrides, from_dict, make_config, to_dict
from mjxmimic.core.errors import UserError
from mjxmimic.core.kinematics import ROOT_BODY, com_velocity
from mjxmimic.physics import randomise
from mjxmimic.physics.randomise import Scales
from mjxmimic.task import events

HAS_WARP = importlib.util.find_spec("warp") is not None
RANDOMISED = {"env.friction_range": "0.3,0.6", "env.mass_range": "0.5,2.0"}


@pytest.mark.parametrize("key, value, named, message", [
    ("env.push_force_max_n", 100.0, "env.push_force_max_n", "at least env.push_force_n"),
    ("env.push_interval_jitter_s", -0.1, "env.push_interval_jitter_s", "must be >= 0"),
    ("env.push_interval_jitter_s", 1.9, "env.push_interval_s", "push_duration_s \\+ env.push_interval_jitter_s"),
    ("env.friction_range", "1.2,0.8", "env.friction_range", "0 < lo <= hi"),
    ("env.friction_range", "0,1", "env.friction_range", "0 < lo <= hi"),
    ("env.friction_range", "1,inf", "env.friction_range", "finite"),
    ("env.mass_range", "1.1", "env.mass_range", "two factors"),
    ("env.mass_range", "heavy", "env.mass_range", "not a valid tuple"),
    ("env.push_ramp_samples", -1, "env.push_ramp_samples", "must be >= 0"),
    ("env.push_ramp_samples", 1000, "env.push_ramp_samples", "set env.events=push too"),
    ("env.push_start_samples", -1, "env.push_start_samples", "must be >= 0"),
    ("env.push_start_samples", 1000, "env.push_start_samples", "set env.events=push too"),
    ("env.push_stop_samples", -1, "env.push_stop_samples", "must be >= 0"),
    ("env.push_stop_samples", 1000, "env.push_stop_samples", "set env.events=push too"),
    ("env.push_episode_share", 0.0, "env.push_episode_share", "must be in \\(0, 1\\]"),
    ("env.push_episode_share", 1.5, "env.push_episode_share", "must be in \\(0, 1\\]"),
    ("env.push_episode_share", 0.5, "env.push_episode_share", "set env.events=push too"),
    ("env.reset_noise_rad", -0.1, "env.reset_noise_rad", "must be >= 0"),
    ("env.reset_velocity_range", "0.5,0.2", "env.reset_velocity_range", "0 <= lo <= hi"),
    ("env.reset_velocity_range", "-0.1,1", "env.reset_velocity_range", "0 <= lo <= hi"),
])
def test_new_keys_are_checked_in_one_line(key, value, named, message):
    with pytest.raises(UserError, match=f"'{named}'.*{message}"):
        make_config("cpu", {"env.push_force_n": 300.0, key: value})


def test_pushes_without_a_force_or_listed_twice_are_refused():
    with pytest.raises(UserError, match="'env.events': push needs a force"):
        make_config("cpu", {"env.events": "push"})
    with pytest.raises(UserError, match="'env.events': 'push' is listed twice"):  # forces add up
        make_config("cpu", {"env.events": "push,push", "env.push_force_n": 300.0})


def test_ranges_are_float_pairs_that_survive_the_json_round_trip():
    config = make_config("cpu", {"env.friction_range": "0.5,1.5", "env.mass_range": [1, 2]})
    assert config.env.friction_range == (0.5, 1.5) and config.env.mass_range == (1.0, 2.0)
    assert from_dict(to_dict(config)) == config
    assert make_config("cpu").env.friction_range == (1.0, 1.0)  # off by default


def test_pushes_draw_their_force_and_start_in_range_and_vary():
    env = make_config("cpu", {"env.push_force_n": 200.0, "env.push_force_max_n": 800.0,
                              "env.push_interval_s": 1.0, "env.push_interval_jitter_s": 0.5}).env
    dt, forces, starts = 1 / 30, [], []
    for seed in np.linspace(0.0, 1.0, 7, endpoint=False):
        wrench = np.stack([events.push(env, k * dt, seed, 3, np)[ROOT_BODY] for k in range(150)])
        force = np.linalg.norm(wrench[:, :2], axis=1)
        assert np.all(force[:30] == 0)  # none in the first interval
        for interval in range(1, 5):
            on = np.flatnonzero(force[30 * interval:30 * (interval + 1)] > 0)
            assert len(on) == 6 and np.all(np.diff(on) == 1)  # one 0.2 s push
            assert on[0] * dt <= 0.5 + 1e-6  # starts within the jitter
            assert 200.0 <= force[30 * interval + on[0]] <= 800.0
            forces.append(force[30 * interval + on[0]])
            starts.append(on[0])
    assert np.ptp(forces) > 300.0 and len(set(starts)) > 5
    # the same numbers in float32 under jit (MJX) as in numpy (the CPU env)
    mjx = jax.jit(lambda t, s: events.push(env, t, s, 3, jnp))(jnp.float32(1.4), jnp.float32(0.3))
    np.testing.assert_allclose(np.asarray(mjx), events.push(env, 1.4, 0.3, 3, np), rtol=1e-4, atol=1e-3)


def test_table6_pushes_go_forward_or_sideways_of_the_facing():
    from mjxmimic.core import quat

    env = make_config("cpu", {"env.push_force_n": 300.0, "env.push_directions": "table6"}).env
    yaw = 0.7  # the character faces 0.7 rad from the world's x axis
    qpos = np.zeros(7)
    qpos[3:7] = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    assert quat.heading(qpos[3:7]) == pytest.approx(yaw)
    turns = []
    for seed in np.linspace(0.0, 1.0, 25, endpoint=False):
        for k in range(1, 9):  # the first 1/30 s of push k
            f = events.push(env, 2.0 * k, seed, 3, np, qpos)[ROOT_BODY]
            assert np.linalg.norm(f[:2]) == pytest.approx(300.0)
            turns.append(round(float(np.angle(np.exp(1j * (np.arctan2(f[1], f[0]) - yaw)))) / (np.pi / 2)))
    share = {t: turns.count(t) / len(turns) for t in set(turns)}
    assert set(share) == {-1, 0, 1} and 0.4 < share[0] < 0.6 and min(share[-1], share[1]) > 0.15
    mjx = jax.jit(lambda t, s, q: events.push(env, t, s, 3, jnp, q))(jnp.float32(2.0), jnp.float32(0.3),
                                                                        jnp.asarray(qpos, jnp.float32))
    np.testing.assert_allclose(np.asarray(mjx), events.push(env, 2.0, 0.3, 3, np, qpos), rtol=1e-4, atol=1e-3)
    with pytest.raises(UserError, match="env.push_directions"):
        make_config("cpu", {"env.push_directions": "backward"})


def test_table6_sideways_pushes_can_be_weaker_than_forward_ones():
    """Table 6's sideways forces are smaller than its forward ones (run 300 against 720 N)."""
    env = make_config("cpu", {"env.push_force_n": 720.0, "env.push_directions": "table6",
                              "env.push_sideways_scale": 300.0 / 720.0}).env
    qpos = np.zeros(7)
    qpos[3] = 1.0  # facing the world's x axis
    seen = set()
    for seed in np.linspace(0.0, 1.0, 25, endpoint=False):
        for k in range(1, 9):
            f = events.push(env, 2.0 * k, seed, 3, np, qpos)[ROOT_BODY]
            sideways = abs(f[1]) > abs(f[0])
            assert np.linalg.norm(f[:2]) == pytest.approx(300.0 if sideways else 720.0)
            seen.add(sideways)
    assert seen == {True, False}
    mjx = jax.jit(lambda t, s, q: events.push(env, t, s, 3, jnp, q))
    for seed in (0.3, 0.8):
        np.testing.assert_allclose(np.asarray(mjx(jnp.float32(2.0), jnp.float32(seed), jnp.asarray(qpos, jnp.float32))),
                                   events.push(env, 2.0, seed, 3, np, qpos), rtol=1e-4, atol=1e-3)
    with pytest.raises(UserError, match="env.push_sideways_scale': scales the sideways pushes"):
        make_config("cpu", {"env.push_sideways_scale": 0.5})
    with pytest.raises(UserError, match="env.push_sideways_scale': must be positive"):
        make_config("cpu", {"env.push_directions": "table6", "env.push_sideways_scale": 0.0})


def test_the_step_pushes_along_the_facing(character):
    from mjxmimic.core import quat
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source

    config = make_config("cpu", {"env.events": "push", "env.push_force_n": 600.0, "env.push_directions": "table6",
                                 "env.action_mode": "residual"})
    env = CpuEnv(config, character, load_clip_source("slow_walk", character))
    env.terminations = ()
    env.reset_at(0.0, event_seed=0.5)
    assert events.sequence(events.DIRECTION, 0.5, 1) < 0.5  # this seed's push 1, at 2 s, goes forward
    for _ in range(60):
        env.step(np.zeros(character.action_size))
    before, facing = env.data.qvel[:2].copy(), quat.heading(env.data.qpos[3:7])
    for _ in range(6):  # the 0.2 s push
        env.step(np.zeros(character.action_size))
    gained = env.data.qvel[:2] - before
    assert np.linalg.norm(gained) > 1.0  # 600 N for 0.2 s on a 45 kg body: about 2.7 m/s
    assert abs(np.angle(np.exp(1j * (np.arctan2(gained[1], gained[0]) - facing)))) < 0.5


def test_factors_are_the_same_bits_on_numpy_and_jax_in_range_and_differ_between_episodes():
    env = make_config("cpu", RANDOMISED).env
    seeds = np.asarray(jax.random.uniform(jax.random.PRNGKey(0), (64,)))
    draw = jax.jit(jax.vmap(lambda s: randomise.draw(env, s, 16, jnp)))(jnp.asarray(seeds))
    for i in (0, 17, 63):
        on_cpu = randomise.draw(env, float(seeds[i]), 16, np)
        np.testing.assert_allclose(np.asarray(draw.mass[i]), on_cpu.mass, rtol=1e-6)
        assert float(draw.friction[i]) == pytest.approx(float(on_cpu.friction), rel=1e-6)
    friction, mass = np.asarray(draw.friction), np.asarray(draw.mass)
    assert np.all((0.3 <= friction) & (friction <= 0.6)) and np.all((0.5 <= mass) & (mass <= 2.0))
    assert len(np.unique(friction)) == 64 and np.ptp(friction) > 0.2
    assert np.ptp(mass, axis=0).min() > 1.0  # every body varies between episodes
    assert np.ptp(mass, axis=1).min() > 0.3  # and the bodies of one episode differ
    assert randomise.draw(make_config("cpu").env, 0.3, 16, np) is None


def _cpu_physics(character, config):
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source

    return CpuEnv(config, character, load_clip_source("slow_walk", character))


def _one_step(cpu, scales, qvel_add=None, force=None, lift=0.0):
    """One control step of the CPU physics from the walk at 0.3 s (lifted by `lift` m, moving
    `qvel_add` faster), zero residual action."""
    from mjxmimic.motion import library as motion
    from mjxmimic.physics.pd import action_to_targets

    qpos, qvel = motion.sample(cpu.spec.lib, 0, np.float32(0.3), np)
    qpos, qvel = np.array(qpos), np.array(qvel) + (0 if qvel_add is None else qvel_add)
    qpos[2] += lift
    cpu.physics.init(qpos, qvel)
    targets = action_to_targets(cpu.spec.layout, np.zeros(cpu.action_size), qpos, "residual", 1.0, np)
    return cpu.physics.step(cpu.data, targets, force, scales).state.qvel.copy()


def test_heavier_bodies_gain_less_speed_from_a_push_and_less_friction_slides_farther(character):
    """MuJoCo C under explicit factors: in the air, twice the mass halves a push's velocity
    change; a sliding character on a tenth of the friction keeps more of its speed."""
    cpu = _cpu_physics(character, make_config("cpu", {"env.action_mode": "residual"}))
    nbody, mass = cpu.model.nbody, cpu.model.body_mass.copy()
    push = np.zeros((nbody, 6))
    push[ROOT_BODY, 0] = 3000.0
    nominal, heavy = Scales(1.0, np.ones(nbody)), Scales(1.0, 2.0 * np.ones(nbody))
    def com_speed(scales, force):  # every body twice as heavy: the same weights in the mean
        qvel = _one_step(cpu, scales, force=force, lift=1.0)
        return com_velocity(cpu.physics.kinematics(cpu.data.qpos, qvel), cpu.spec.layout.body_mass, np)[0]

    gain = {s: com_speed(scales, push) - com_speed(scales, None) for s, scales in (("nominal", nominal), ("heavy", heavy))}
    assert gain["nominal"] == pytest.approx(3000.0 / 30 / 45.0, rel=0.02)  # momentum F dt on 45 kg
    assert gain["heavy"] == pytest.approx(0.5 * gain["nominal"], rel=0.02)
    np.testing.assert_array_equal(cpu.model.body_mass, mass)  # a copy was scaled, not the nominal model
    slide = np.zeros(cpu.model.nv)
    slide[0] = 3.0  # the whole body moving forward at 3 m/s, feet on the floor
    keep = {f: _one_step(cpu, Scales(f, np.ones(nbody)), qvel_add=slide)[0] for f in (1.0, 0.1)}
    assert keep[0.1] > keep[1.0] + 0.05  # 3.67 against 3.58 m/s
    # the unscaled copy steps exactly as the nominal model does
    np.testing.assert_array_equal(_one_step(cpu, nominal, force=push), _one_step(cpu, None, force=push))
    assert cpu.physics.stepped_model(None) is cpu.model


@pytest.mark.slow
def test_mjx_steps_each_env_under_its_own_factors_as_mujoco_c_does(residual_env, character):
    """A randomised env (a fresh compile), two episodes with different event seeds, pushed in the
    air (no contact solve, where the two simulators agree to float32 rounding): MJX steps them
    apart, each as the CPU env does with the same seed and unlike the nominal model; both step
    the same friction, masses and inertias; the metrics log the draw."""
    from mjxmimic.envs.mjx_env import ImitationEnv

    cfg = apply_overrides(residual_env.config, RANDOMISED)
    nominal = apply_overrides(cfg, {"env.friction_range": "1,1", "env.mass_range": "1,1"})
    env = ImitationEnv(cfg, character, residual_env.clips)
    states = jax.jit(jax.vmap(lambda k: env.reset_at(k, 0.3)))(jax.random.split(jax.random.PRNGKey(3), 2))
    data = states.pipeline_state
    states = states.replace(pipeline_state=data.replace(qpos=data.qpos.at[:, 2].add(1.0)))  # 1 m up
    push = np.zeros((env.model.nbody, 6), np.float32)
    push[ROOT_BODY, 0] = 2000.0
    transition = jax.jit(jax.vmap(lambda s, a: env.transition(s, a, external_force=jnp.asarray(push))))
    nxt = transition(states, jnp.zeros((2, env.action_size)))
    mjx_qvel = np.asarray(nxt.pipeline_state.qvel)
    assert np.abs(mjx_qvel[0] - mjx_qvel[1]).max() > 0.1
    seeds = np.asarray(states.info["event_seed"])
    for i in range(2):
        scales = randomise.draw(cfg.env, float(seeds[i]), env.model.nbody, np)
        assert float(nxt.metrics["randomise/friction"][i]) == pytest.approx(float(scales.friction), rel=1e-6)
        assert float(nxt.metrics["randomise/mass"][i]) == pytest.approx(float(scales.mass[1:].mean()), rel=1e-5)
        q, v = (np.asarray(x[i]) for x in (states.pipeline_state.qpos, states.pipeline_state.qvel))
        runs = {}
        for name, config in (("randomised", cfg), ("nominal", nominal)):
            cpu = _cpu_physics(character, config)
            cpu.set_state(q, v, 0.3, event_seed=float(seeds[i]))
            cpu.step(np.zeros(env.action_size), external_force=push)
            runs[name] = cpu.data.qvel.copy()
        np.testing.assert_allclose(runs["randomised"], mjx_qvel[i], atol=1e-3)
        assert np.abs(runs["nominal"] - mjx_qvel[i]).max() > 0.1
        stepped = env.physics.model(Scales(jnp.float32(scales.friction), jnp.asarray(scales.mass)))
        for field in ("body_mass", "body_inertia", "geom_friction"):
            np.testing.assert_allclose(np.asarray(getattr(stepped, field)),
                                       getattr(cpu.physics.stepped_model(scales), field), rtol=1e-6)


def test_off_by_default_the_model_and_the_pushes_are_as_before(residual_env):
    """No randomisation: MJX steps its nominal model itself and logs nothing more; without the
    new push keys a push is bit for bit the fixed force it was (direction by the golden ratio)."""
    assert not randomise.enabled(residual_env.config.env)
    assert residual_env.physics.model(None) is residual_env.physics.sys
    assert "randomise/mass" not in residual_env.metric_keys
    env = make_config("cpu", {"env.push_force_n": 300.0}).env
    for seed, t in ((0.3, 2.0), (0.71, 4.1), (0.05, 6.15)):
        k = np.floor(t / env.push_interval_s)
        turn = 2.0 * np.pi * ((seed + events.GOLDEN * k) % 1.0)
        wrench = events.push(env, t, seed, 3, np)[ROOT_BODY]
        np.testing.assert_array_equal(wrench, np.float32([300.0 * np.cos(turn), 300.0 * np.sin(turn), 0, 0, 0, 0]))


def test_the_curriculum_scales_every_push():
    env = make_config("cpu", {"env.push_force_n": 300.0, "env.push_force_max_n": 900.0,
                              "env.push_directions": "table6"}).env
    qpos = np.zeros(7)
    qpos[3] = 1.0
    full = events.push(env, 2.05, 0.3, 3, np, qpos)
    assert np.abs(full).max() > 300.0
    np.testing.assert_allclose(events.push(env, 2.05, 0.3, 3, np, qpos, 0.25), 0.25 * full, rtol=1e-6)
    assert not events.push(env, 2.05, 0.3, 3, np, qpos, 0.0).any()
    assert events.external_force(("push",), env, 2.05, 0.3, 3, np, qpos, 0.5) == pytest.approx(0.5 * full)


def test_pushes_stop_only_after_the_full_pushes_have_come():
    with pytest.raises(UserError, match="'env.push_stop_samples'.*after env.push_start_samples"):
        make_config("cpu", {"env.events": "push", "env.push_force_n": 300.0, "env.push_start_samples": 1000,
                            "env.push_ramp_samples": 1000, "env.push_stop_samples": 2000})


def test_a_share_of_the_episodes_is_pushed_picked_by_the_event_seed():
    """env.push_episode_share: an episode is pushed at every push time or at none, by its event
    seed alone, the share of episodes pushed is the one asked for, and MJX agrees with numpy."""
    every = make_config("cpu", {"env.events": "push", "env.push_force_n": 300.0}).env
    half = make_config("cpu", {"env.events": "push", "env.push_force_n": 300.0, "env.push_episode_share": 0.5}).env
    times = 2.05 + 2.0 * np.arange(5)  # inside the pushes of intervals 1 to 5
    pushed = []
    for seed in np.linspace(0.0, 1.0, 1000, endpoint=False):
        forces = [np.abs(events.push(half, t, seed, 3, np)).max() for t in times]
        assert all(f == 0 for f in forces) or all(f > 0 for f in forces)  # the whole episode or none
        pushed.append(forces[0] > 0)
        if pushed[-1]:
            np.testing.assert_array_equal(events.push(half, 2.05, seed, 3, np), events.push(every, 2.05, seed, 3, np))
    assert np.mean(pushed) == pytest.approx(0.5, abs=0.02)
    on_mjx = jax.jit(lambda s: events.push(half, jnp.float32(2.05), s, 3, jnp))
    both = [(s, on_mjx(jnp.float32(s))) for s in (0.01, 0.02, 0.03, 0.3, 0.6, 0.9)]
    assert {bool(np.abs(np.asarray(m)).max() > 0) for _, m in both} == {True, False}
    for s, m in both:
        np.testing.assert_allclose(np.asarray(m), events.push(half, 2.05, s, 3, np), rtol=1e-4, atol=1e-3)


def test_runs_with_pushes_measure_the_pose_termination_from_the_root_unless_told():
    assert make_config("gpu").env.pose_termination_frame == "world"
    assert make_config("gpu", {"env.events": "push", "env.push_force_n": 100}).env.pose_termination_frame == "root"
    told = make_config("gpu", {"env.events": "push", "env.push_force_n": 100, "env.pose_termination_frame": "world"})
    assert told.env.pose_termination_frame == "world"


def test_a_push_opens_a_settle_window_and_keeps_the_world_frame(character):
    """env.push_settle_s: from a push until that long after its end the reference root follows the
    character and a pose deviation ends no training episode; then the world-frame rule applies
    again. Without it the same push ends the episode on the pose rule."""
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source

    pushes = {"env.events": "push", "env.push_force_n": 1500.0, "env.push_interval_s": 0.5,
              "env.action_mode": "residual", "env.pose_termination_m": 1.0}
    clip = load_clip_source("slow_walk", character)

    def pushed_run(settle_s: float) -> tuple[list, list, bool]:  # failed and settle per step; root followed
        config = make_config("cpu", {**pushes, "env.push_settle_s": settle_s, "env.pose_termination_frame": "world"})
        env = CpuEnv(config, character, clip)
        env.terminations = ("pose_deviation",)  # the training rule alone: no fall ends these episodes
        env.reset_at(0.0, event_seed=0.5)
        failed, settle, followed = [], [], True
        for _ in range(30):  # the first push: steps 15 to 20 (0.5 to 0.7 s), unsteered
            failed.append(bool(env.step(np.zeros(character.action_size)).failed))
            settle.append(int(env.motion.settle))
            if settle[-1] > 0:
                ref, _ = env.reference(env.time)
                followed &= bool(np.allclose(ref[0:2], env.data.qpos[0:2], atol=1e-6))
        return failed, settle, followed

    failed, settle, _ = pushed_run(0.0)
    assert not any(failed[:15]) and any(failed[15:23]) and not any(settle)  # 1500 N carry the root 1 m off
    failed, settle, followed = pushed_run(0.2)
    assert settle[15:25] == [5] * 6 + [4, 3, 2, 1] and followed  # 0.2 s of control steps after the push
    assert not any(failed[:25]) and any(failed[25:])  # the rule applies again once the window closes
    assert make_config("cpu", {**pushes, "env.push_settle_s": 0.5}).env.pose_termination_frame == "world"
    assert make_config("cpu", pushes).env.pose_termination_frame == "root"
    with pytest.raises(UserError, match="'env.push_settle_s'.*set env.events=push too"):
        make_config("cpu", {"env.push_settle_s": 0.5})
    with pytest.raises(UserError, match="'env.push_settle_s'.*must be >= 0"):
        make_config("cpu", {**pushes, "env.push_settle_s": -1.0})


@pytest.mark.slow
def test_the_env_pushes_by_the_curriculum_factor_and_keeps_it_through_restarts(character):
    """MJX: the factor in the state's info scales the push the step applies, and an episode that
    restarts keeps the factor the trainer set (a fresh episode must not push at full force)."""
    from mjxmimic.envs.mjx_env import ImitationEnv
    from mjxmimic.motion.clip import load_clip_source

    config = make_config("cpu", {"env.events": "push", "env.push_force_n": 600.0, "env.push_ramp_samples": 10**6,
                                 "physics.backend": "jax", "env.early_termination": False})
    env = ImitationEnv(config, character, [load_clip_source("slow_walk", character)])
    start = env.reset_at(jax.random.PRNGKey(0), 0.0)
    assert float(start.info[events.PUSH_SCALE]) == 1.0
    transition = jax.jit(env.transition)
    zeros = jnp.zeros(env.action_size)

    def speed_gained(scale: float) -> float:  # over the first push (at 2 s, 0.2 s long)
        state = start.replace(info=start.info | {events.PUSH_SCALE: jnp.float32(scale)})
        for _ in range(60):
            state = transition(state, zeros)
        before = np.asarray(state.pipeline_state.qvel[:2])
        for _ in range(6):
            state = transition(state, zeros)
        return np.asarray(state.pipeline_state.qvel[:2]) - before

    none, half, full = speed_gained(0.0), speed_gained(0.5), speed_gained(1.0)
    assert np.linalg.norm(full - none) > 1.0  # 600 N for 0.2 s on a 45 kg body: about 2.7 m/s
    assert np.linalg.norm(half - none) == pytest.approx(0.5 * np.linalg.norm(full - none), rel=0.2)

    last = start.info | {"steps": jnp.int32(env.max_steps - 1), events.PUSH_SCALE: jnp.float32(0.25)}
    restarted = jax.jit(env.step)(start.replace(info=last), zeros)
    assert int(restarted.info["steps"]) == 0 and float(restarted.info[events.PUSH_SCALE]) == 0.25


@pytest.mark.slow
@pytest.mark.skipif(not HAS_WARP, reason="warp-lang not installed")
def test_warp_batches_the_randomised_fields_as_jax_does(character):
    """MJX-Warp (here on the CPU) takes per-env masses and friction under vmap and steps as
    MJX-JAX does."""
    from mjxmimic.envs.step import build
    from mjxmimic.motion import library as motion
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.physics.mjx import MjxPhysics
    from mjxmimic.physics.pd import action_to_targets

    config = make_config("cpu", {"env.solver_iterations": 30, "env.ls_iterations": 30})
    scene, spec = build(config, character, [load_clip_source("slow_walk", character)], jnp)
    nbody = scene.model.nbody
    qpos, qvel = motion.sample(spec.lib, 0, jnp.float32(0.3), jnp)
    targets = action_to_targets(spec.layout, jnp.zeros(character.action_size), qpos, "residual", 1.0, jnp)
    push = jnp.zeros((nbody, 6)).at[ROOT_BODY, 0].set(2000.0)
    scales = Scales(friction=jnp.array([1.0, 0.2, 1.0]), mass=jnp.stack([jnp.ones(nbody), jnp.ones(nbody),
                                                                           2.0 * jnp.ones(nbody)]))
    out = {}
    for impl in ("jax", "warp"):
        physics = MjxPhysics(scene, spec.layout, 4, "total", impl, max_worlds=3)
        one = lambda s: physics.step(physics.init(qpos, qvel), targets, push, s).state.qvel
        out[impl] = np.asarray(jax.jit(jax.vmap(one))(scales))
    np.testing.assert_allclose(out["warp"], out["jax"], atol=0.02)
    assert np.abs(out["warp"][0] - out["warp"][1]).max() > 0.05  # less friction
    assert out["warp"][2, 0] < out["warp"][0, 0] - 0.3  # heavier: less speed from the push


def test_training_perturbations_stay_out_of_evaluation(tmp_path, monkeypatch):
    """NR, push tests and playback grade a push-trained, randomised policy as any other: the
    evaluation config drops the events and the ranges, and training's evaluator gets an env
    built from it, also when the caller built the training env (as `mjxmimic train` does)."""
    import sys
    from pathlib import Path

    from mjxmimic.core.config import evaluation_config
    from mjxmimic.runs.train_loop import train

    sys.path.insert(0, str(Path(__file__).parent))
    from standin_env import StandInEnv

    config = make_config("cpu", {**RANDOMISED, "env.events": "push", "env.push_force_n": 300.0,
                                 "env.reset_noise_rad": 0.2, "run.total_samples": 512, "run.eval_every": 512,
                                 "run.eval_at_start": "false"})
    graded = evaluation_config(config)
    assert (graded.env.events, graded.env.friction_range, graded.env.mass_range) == ("", (1.0, 1.0), (1.0, 1.0))
    assert evaluation_config(apply_overrides(config, {"env.push_ramp_samples": 1000})) == graded
    assert evaluation_config(apply_overrides(config, {"env.push_start_samples": 1000})) == graded
    assert evaluation_config(apply_overrides(config, {"env.push_stop_samples": 1000})) == graded
    assert evaluation_config(apply_overrides(config, {"env.push_episode_share": 0.5})) == graded
    assert graded.env.reset_noise_rad == 0.0
    assert graded.ppo == config.ppo and graded.env.control_hz == config.env.control_hz
    assert evaluation_config(graded) == graded
    built = []

    def factory(cfg, run_dir=None):  # make_env's signature, for the monkeypatch below
        built.append(cfg)
        return StandInEnv()

    train(config, tmp_path / "run", env_factory=factory, progress=False)
    assert built == [config, graded]  # the training env, then the evaluator's
    built.clear()
    monkeypatch.setattr("mjxmimic.envs.mjx_env.make_env", factory)
    train(config, tmp_path / "given", env=StandInEnv(), progress=False)
    assert built == [graded]


def test_reset_noise_turns_every_joint_within_its_bound_alike_on_numpy_and_jax(character):
    """env.reset_noise_rad: the RSI pose with each hinge moved by up to the bound and each ball
    joint turned by a rotation vector of components up to it; the root and the velocities are
    the reference's; the same pose from the same event seed on numpy (the CPU env) and JAX (MJX),
    another from another seed."""
    from mjxmimic.core import quat
    from mjxmimic.envs import starts, step
    from mjxmimic.motion.clip import load_clip_source

    clip, noise, t = load_clip_source("slow_walk", character), 0.3, np.float32(0.4)
    noisy = make_config("cpu", {"env.reset_noise_rad": noise})
    spec_np = step.build(noisy, character, [clip], np)[1]
    spec_jax = step.build(noisy, character, [clip], jnp)[1]
    plain = step.build(make_config("cpu"), character, [clip], np)[1]
    ref_q, ref_v = starts.start_state(plain, 0, t, np.float32(0.37), np)
    q, v = starts.start_state(spec_np, 0, t, np.float32(0.37), np)
    q_jax = np.asarray(starts.start_state(spec_jax, 0, jnp.float32(t), jnp.float32(0.37), jnp)[0])
    np.testing.assert_allclose(q_jax, q, atol=1e-6)
    np.testing.assert_array_equal(v, ref_v)
    np.testing.assert_array_equal(q[:7], ref_q[:7])
    layout = spec_np.layout
    hinge = np.abs(q[layout.q_scalar[3:]] - ref_q[layout.q_scalar[3:]])
    assert hinge.max() <= noise + 1e-6 and hinge.max() > 0.5 * noise
    turn = np.array([quat.angle_between(a, b, np) for a, b in zip(q[layout.q_quat[1:]], ref_q[layout.q_quat[1:]])])
    assert turn.max() <= np.sqrt(3) * noise + 1e-5 and turn.min() > 0.01
    assert np.abs(starts.start_state(spec_np, 0, t, np.float32(0.61), np)[0] - q).max() > 0.05


def test_reset_velocity_range_scales_the_start_velocities_by_one_factor_alike_on_numpy_and_jax(character):
    """env.reset_velocity_range: the RSI velocities, root and joints, times one factor in the range
    drawn from the event seed (the same on numpy and JAX), the pose untouched; other seeds draw
    other factors; evaluation drops it."""
    from mjxmimic.core.config import evaluation_config
    from mjxmimic.envs import starts, step
    from mjxmimic.motion.clip import load_clip_source

    clip, t = load_clip_source("slow_walk", character), np.float32(0.4)
    slowed = make_config("cpu", {"env.reset_velocity_range": "0.2,0.6"})
    spec_np = step.build(slowed, character, [clip], np)[1]
    spec_jax = step.build(slowed, character, [clip], jnp)[1]
    plain = step.build(make_config("cpu"), character, [clip], np)[1]
    ref_q, ref_v = starts.start_state(plain, 0, t, np.float32(0.37), np)
    factors = []
    for seed in (0.37, 0.61, 0.05, 0.93):
        q, v = starts.start_state(spec_np, 0, t, np.float32(seed), np)
        v_jax = np.asarray(starts.start_state(spec_jax, 0, jnp.float32(t), jnp.float32(seed), jnp)[1])
        np.testing.assert_array_equal(q, ref_q)
        np.testing.assert_allclose(v_jax, v, rtol=1e-6, atol=1e-7)
        factor = v[np.abs(ref_v).argmax()] / ref_v[np.abs(ref_v).argmax()]
        np.testing.assert_allclose(v, factor * ref_v, rtol=1e-5, atol=1e-6)
        factors.append(factor)
    assert min(factors) >= 0.2 - 1e-6 and max(factors) <= 0.6 + 1e-6 and max(factors) - min(factors) > 0.05
    assert evaluation_config(slowed).env.reset_velocity_range == (1.0, 1.0)
