"""The MJX imitation environment on the project's own walk clip: reward, RSI, ET, stability, the
NaN guard, several clips at once, parity with C MuJoCo."""

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from mjxmimic.motion import library as motion
from mjxmimic.core import quat
from mjxmimic.core.config import apply_overrides, make_config
from mjxmimic.physics.pd import action_to_targets, pd_forces
from mjxmimic.envs.mjx_env import ImitationEnv
from mjxmimic.core.kinematics import ROOT_BODY, kin_from_data
from mjxmimic.motion.clip import load_clip_source
from mjxmimic.task.observation import DEFAULT, observe, parse
from mjxmimic.task import termination
from mjxmimic.task.reward import reward, terms

RELEASED, PAPER = terms("released"), terms("paper")


def observation(k, phase, xp):
    return observe(parse(DEFAULT), k, phase, xp)


@pytest.fixture(scope="module")
def env(residual_env):
    return residual_env


@pytest.fixture(scope="module")
def transition(env_fns):
    return env_fns.transition


@pytest.fixture(scope="module")
def reset_at(env_fns):
    return env_fns.reset_at


def c_kin(model, qpos, qvel):
    """Kinematics through MuJoCo's C library."""
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_comVel(model, data)
    return kin_from_data(data, np)


def random_state(env, rng):
    """A random pose and velocity: random ball-joint rotations, hinge angles in range."""
    qpos, qvel = motion.sample(env.spec.lib, 0, rng.uniform(0, env.clip_duration))
    qpos, qvel = np.asarray(qpos, np.float64).copy(), np.asarray(qvel, np.float64).copy()
    lay = env.spec.layout
    qpos[lay.q_quat] = quat.normalize(rng.normal(size=lay.q_quat.shape))
    qpos[lay.q_scalar[3:]] = rng.uniform(lay.hinge_low, lay.hinge_high)
    qvel += rng.normal(scale=1.0, size=qvel.shape)
    return qpos, qvel


def test_reward_and_every_term_are_one_at_the_reference(env):
    for t in np.linspace(0.0, 1.3, 6):
        qpos, qvel = motion.sample(env.spec.lib, 0, t)
        k = c_kin(env.model, qpos, qvel)
        total, terms = reward(RELEASED, env.spec.layout, k, k, np)
        assert total == pytest.approx(1.0, abs=1e-4)
        for name, value in terms.items():
            if name.startswith("reward/"):
                assert value == pytest.approx(1.0, abs=1e-4), name
        paper, _ = reward(PAPER, env.spec.layout, k, k, np)
        assert paper == pytest.approx(1.0, abs=1e-4)


def test_reward_falls_as_pose_noise_grows(env):
    rng = np.random.default_rng(0)
    lay = env.spec.layout
    means = []
    for sigma in (0.0, 0.05, 0.1, 0.2, 0.4, 0.8):
        values = []
        for t in np.linspace(0.1, 1.2, 8):
            qpos, qvel = motion.sample(env.spec.lib, 0, t)
            qpos = np.asarray(qpos, np.float64)
            ref = c_kin(env.model, qpos, qvel)
            noisy = qpos.copy()
            turn = quat.from_rotvec(rng.normal(scale=sigma, size=(len(lay.q_quat), 3)))
            noisy[lay.q_quat] = quat.mul(noisy[lay.q_quat], turn)
            noisy[lay.q_scalar[3:]] += rng.normal(scale=sigma, size=len(lay.q_scalar) - 3)
            values.append(reward(RELEASED, lay, c_kin(env.model, noisy, qvel), ref, np)[0])
        means.append(np.mean(values))
    assert means[0] == pytest.approx(1.0, abs=1e-4)
    assert all(a > b for a, b in zip(means, means[1:])), means
    assert means[-1] < 0.5


def test_paper_form_is_the_papers_equations_without_weights(env):
    """DEEPMIMIC.md: the paper's sums carry no per-joint weights and grade world positions."""
    lay = env.spec.layout
    qpos, qvel = motion.sample(env.spec.lib, 0, 0.4)
    qpos, qvel = np.asarray(qpos, np.float64), np.asarray(qvel, np.float64)
    ref = c_kin(env.model, qpos, qvel)
    bent, fast = qpos.copy(), qvel.copy()
    hinges = lay.q_scalar[3:][:2]  # two hinges turned by 0.1 and 0.2 rad, one sped up by 3 rad/s
    bent[hinges] += (0.1, 0.2)
    fast[lay.v_scalar[3:][0]] += 3.0
    sim = c_kin(env.model, bent, fast)
    by_name = {t.name: t for t in PAPER}
    assert by_name["pose"].error(lay, sim, ref, np) == pytest.approx(0.1**2 + 0.2**2, rel=1e-4)
    assert by_name["velocity"].error(lay, sim, ref, np) == pytest.approx(9.0, rel=1e-4)
    moved = qpos.copy()
    moved[0] += 0.5  # the whole body half a metre along x: the heading-frame errors would be 0
    sim = c_kin(env.model, moved, qvel)
    assert by_name["pose"].error(lay, sim, ref, np) == pytest.approx(0.0, abs=1e-8)
    assert by_name["end_effector"].error(lay, sim, ref, np) == pytest.approx(0.25 * len(lay.end_effectors), rel=1e-6)
    assert by_name["com"].error(lay, sim, ref, np) == pytest.approx(0.25, rel=1e-6)


def test_reset_state_is_the_reference_and_scores_one(env, transition, reset_at):
    state = reset_at(jax.random.PRNGKey(0), 0.4)
    qpos, _ = motion.sample(env.spec.lib, 0, 0.4)
    np.testing.assert_allclose(state.pipeline_state.qpos, qpos, atol=1e-6)
    assert state.obs.shape == (env.observation_size,) == (227,)
    nxt = transition(state, jnp.zeros(env.action_size))  # PD toward the reference, one step
    assert float(nxt.reward) > 0.7
    assert float(nxt.done) == 0.0


def test_reference_root_moves_under_the_character_at_each_new_cycle(env, transition, reset_at):
    """DeepMimic's sync_char_root_pos: a character 0.5 m beside its reference loses root reward
    until the next cycle starts, then the reference root is moved under it (and not before)."""
    dt = env.control_dt

    def shifted(t):
        state = reset_at(jax.random.PRNGKey(0), t)
        data = state.pipeline_state
        return state.replace(pipeline_state=data.replace(qpos=data.qpos.at[0:2].add(jnp.array([0.3, -0.4]))))

    mid = transition(shifted(0.5), jnp.zeros(env.action_size))
    np.testing.assert_array_equal(mid.info["root_offset"], 0.0)
    assert float(mid.metrics["reward/root"]) < 0.35  # exp(-5 * 0.25)

    crossing = transition(shifted(env.clip_duration - 0.5 * dt), jnp.zeros(env.action_size))
    ref_qpos, _ = motion.sample(env.spec.lib, 0, float(crossing.info["time"]))
    np.testing.assert_allclose(crossing.info["root_offset"],
                               crossing.pipeline_state.qpos[0:2] - ref_qpos[0:2], atol=1e-5)
    assert float(crossing.metrics["reward/root"]) > 0.8

    unsynced = ImitationEnv(apply_overrides(env.config, {"reward.sync_root_position": False}),
                            env.character, env.clips)
    crossing = jax.jit(unsynced.transition)(shifted(env.clip_duration - 0.5 * dt), jnp.zeros(env.action_size))
    assert float(crossing.metrics["reward/root"]) < 0.35


def test_rsi_draws_a_fresh_start_on_every_reset(env, env_fns, reset_at):
    """Auto-reset (one env, many episodes) must not replay a cached first state."""
    step = env_fns.step
    state = reset_at(jax.random.PRNGKey(1), 0.1)
    starts = []
    for _ in range(120):
        state = state.replace(info=dict(state.info, steps=jnp.asarray(env.max_steps - 1, jnp.int32)))
        state = step(state, jnp.zeros(env.action_size))
        assert float(state.done) == 1.0 and float(state.info["truncation"]) == 1.0
        starts.append(float(state.info["time"]))
    starts = np.array(starts)
    counts, _ = np.histogram(starts, bins=4, range=(0, env.clip_duration))
    assert len(np.unique(starts)) == len(starts)
    assert counts.min() >= 10, counts  # spread over the whole clip


def test_early_termination_on_chest_contact_not_on_feet(env, transition, reset_at):
    standing = reset_at(jax.random.PRNGKey(0), 0.0)
    after = transition(standing, jnp.zeros(env.action_size))
    assert float(after.metrics["fell"]) == 0.0 and float(after.done) == 0.0  # feet on the floor

    lying = np.asarray(standing.pipeline_state.qpos).copy()
    lying[2] = 0.08  # root at chest-radius height ...
    lying[3:7] = quat.from_rotvec(np.array([0.0, np.pi / 2, 0.0]))  # ... lying face down
    state = standing.replace(pipeline_state=standing.pipeline_state.replace(qpos=jnp.asarray(lying)))
    after = transition(state, jnp.zeros(env.action_size))
    assert float(after.metrics["fell"]) == 1.0 and float(after.done) == 1.0
    assert float(after.reward) == 0.0 and float(after.info["truncation"]) == 0.0


def test_pose_termination_ends_training_episodes_that_lose_the_reference(env, transition, reset_at):
    standing = reset_at(jax.random.PRNGKey(0), 0.5)
    data = standing.pipeline_state
    away = standing.replace(pipeline_state=data.replace(qpos=data.qpos.at[1].add(0.5)))  # 0.5 m aside
    zero = jnp.zeros(env.action_size)
    assert float(transition(away, zero).done) == 0.0  # off by default (DeepMimic's)

    sim = c_kin(env.model, np.asarray(away.pipeline_state.qpos), np.asarray(away.pipeline_state.qvel))
    ref = c_kin(env.model, np.asarray(standing.pipeline_state.qpos), np.asarray(standing.pipeline_state.qvel))
    for metres, lost in ((0.3, True), (0.8, False)):  # the training-only term, 0.5 m away
        o = termination.Outcome(sim=sim, ref=ref, contacts=None, fall_mask=None, reference_geoms=None,
                                diverged=False, max_joint_velocity=100.0, pose_termination_m=metres)
        assert bool(termination.pose_deviation(o, np)) == lost
        # measured from the root, the same pose 0.5 m aside has not lost the reference
        assert not bool(termination.pose_deviation(o._replace(pose_from_root=True), np))
    qpos = np.asarray(standing.pipeline_state.qpos).copy()
    qpos[1] += 0.5
    qpos[2] += 0.5  # also 0.5 m higher: the height still counts
    up = c_kin(env.model, qpos, np.asarray(standing.pipeline_state.qvel))
    o = termination.Outcome(sim=up, ref=ref, contacts=None, fall_mask=None, reference_geoms=None, diverged=False,
                            max_joint_velocity=100.0, pose_termination_m=0.3, pose_from_root=True)
    assert bool(termination.pose_deviation(o, np))
    assert termination.training_list(0.3) == ("fall", "bad_state", "pose_deviation")
    assert "pose_deviation" not in termination.evaluation_list()


@pytest.mark.slow
def test_pose_termination_in_the_env_is_a_training_failure(env, reset_at):
    standing = reset_at(jax.random.PRNGKey(0), 0.5)
    data = standing.pipeline_state
    away = standing.replace(pipeline_state=data.replace(qpos=data.qpos.at[1].add(0.5)))  # 0.5 m aside
    zero = jnp.zeros(env.action_size)
    near = ImitationEnv(apply_overrides(env.config, {"env.pose_termination_m": 0.3}), env.character, env.clips)
    after = jax.jit(near.transition)(away, zero)
    assert float(after.metrics["lost_track"]) == 1.0 and float(after.done) == 1.0
    assert float(after.metrics["fell"]) == 0.0 and float(after.reward) == 0.0
    assert float(after.info["truncation"]) == 0.0  # a failure, not a timeout
    from_root = ImitationEnv(apply_overrides(env.config, {"env.pose_termination_m": 0.3,
                                                          "env.pose_termination_frame": "root"}),
                             env.character, env.clips)
    after = jax.jit(from_root.transition)(away, zero)
    assert float(after.metrics["lost_track"]) == 0.0 and float(after.done) == 0.0


@pytest.mark.slow
def test_hundred_steps_on_four_envs_stay_finite(env):
    reset = jax.jit(jax.vmap(env.reset))
    step = jax.jit(jax.vmap(env.step))
    state = reset(jax.random.split(jax.random.PRNGKey(2), 4))
    key = jax.random.PRNGKey(3)
    for _ in range(100):
        key, sub = jax.random.split(key)
        state = step(state, jax.random.uniform(sub, (4, env.action_size), minval=-1, maxval=1))
        assert bool(jnp.all(jnp.isfinite(state.obs))) and bool(jnp.all(jnp.isfinite(state.reward)))
    assert bool(jnp.all((state.reward >= 0) & (state.reward <= 1)))


def test_kinematics_and_observation_match_mujoco_c(env):
    """MJX kinematics vs C MuJoCo on random poses; the same observation code on both (numpy/JAX)."""
    rng = np.random.default_rng(4)
    fk = jax.jit(env.physics.kinematics)
    for _ in range(5):
        qpos, qvel = random_state(env, rng)
        c = c_kin(env.model, qpos, qvel)
        j = fk(jnp.asarray(qpos, jnp.float32), jnp.asarray(qvel, jnp.float32))
        for name in ("xipos", "xmat", "angvel", "linvel", "com"):
            np.testing.assert_allclose(np.asarray(getattr(j, name)), getattr(c, name), atol=2e-4, err_msg=name)
        phase = rng.uniform()
        np.testing.assert_allclose(np.asarray(observation(j, jnp.asarray(phase), jnp)),
                                   observation(c, np.asarray(phase), np), atol=5e-4)


def test_results_name_their_simulator_and_its_version(env):
    """A push test's forces differ between MJX's implementations and MuJoCo C, so every NR and
    push result says which one made it (the `simulator` field)."""
    from importlib.metadata import version

    from mjxmimic.physics.cpu import CpuPhysics

    assert env.physics.simulator == f"mujoco-mjx {version('mujoco-mjx')} (impl jax, cpu)"
    assert CpuPhysics.simulator == f"mujoco {mujoco.__version__} (CPU, mj_step)"


def test_pd_law_is_the_same_in_numpy_and_jax(env):
    rng = np.random.default_rng(5)
    for _ in range(5):
        qpos, qvel = random_state(env, rng)
        action = rng.uniform(-1, 1, env.action_size)
        for mode, law in (("absolute", "total"), ("residual", "total"), ("residual", "proportional")):
            t_np = action_to_targets(env.spec.layout, action, qpos, mode, 0.5, np)
            f_np = pd_forces(env.spec.layout, qpos, qvel, t_np, 1 / 240, np, law)
            t_j = action_to_targets(env.spec.layout, jnp.asarray(action), jnp.asarray(qpos), mode, 0.5, jnp)
            f_j = pd_forces(env.spec.layout, jnp.asarray(qpos), jnp.asarray(qvel), t_j, 1 / 240, jnp, law)
            np.testing.assert_allclose(np.asarray(f_j), f_np, rtol=1e-4, atol=1e-2)
            assert np.all(f_np[:6] == 0)  # the root is not actuated


def test_torque_limit_bounds_the_whole_pd_torque_damping_included(env):
    """A knee swinging at 10 rad/s towards a far target: DeepMimic's "total" law lets the joint
    push with its full limit (applied force minus MuJoCo's damping -kd qdot stays within it); the
    "proportional" law clamps only kp's part, so damping (kd 50 x 10 = 500 N m) overwhelms it."""
    lay = env.spec.layout
    qpos, qvel = motion.sample(env.spec.lib, 0, 0.3)
    qpos, qvel = np.asarray(qpos, np.float64).copy(), np.zeros(env.model.nv)
    knee_q, knee_v = lay.q_scalar[3], lay.v_scalar[3]
    qpos[knee_q], qvel[knee_v] = -1.5, 10.0
    targets = action_to_targets(lay, np.zeros(env.action_size), qpos, "residual", 1.0, np)
    targets = targets._replace(hinge=targets.hinge.copy())
    targets.hinge[0] = 0.0  # 1.5 rad ahead, in the direction of motion
    kd, limit = lay.hinge_kd[0], lay.hinge_limit[0]
    net = {law: pd_forces(lay, qpos, qvel, targets, 1 / 240, np, law)[knee_v] - kd * 10.0
           for law in ("total", "proportional")}
    assert net["total"] == pytest.approx(limit, rel=1e-5)  # kp (1.5 - 10/240) - 500 > 150: clamped
    assert net["proportional"] == pytest.approx(limit - kd * 10.0, rel=1e-5)  # 150 - 500
    rng = np.random.default_rng(9)
    for _ in range(5):  # and in general: every joint's net torque within its limit
        qpos, qvel = random_state(env, rng)
        qvel *= 5.0
        t = action_to_targets(lay, rng.uniform(-1, 1, env.action_size), qpos, "absolute", 1.0, np)
        f = pd_forces(lay, qpos, qvel, t, 1 / 240, np, "total")
        net_h = f[lay.v_scalar[3:]] - lay.hinge_kd * qvel[lay.v_scalar[3:]]
        net_b = f[lay.v_ang[1:]] - lay.ball_kd[:, None] * qvel[lay.v_ang[1:]]
        assert np.all(np.abs(net_h) <= lay.hinge_limit * (1 + 1e-6))
        assert np.all(np.linalg.norm(net_b, axis=1) <= lay.ball_limit * (1 + 1e-6))


def test_a_nan_state_is_reset_counted_and_not_a_fall(env, env_fns, reset_at):
    """The guard: a state that turned NaN is reset at once, counted under physics/reset_nan,
    scores 0, and is a cut episode (truncation, masked out of GAE), not a fall."""
    state = reset_at(jax.random.PRNGKey(0), 0.2)
    data = state.pipeline_state
    broken = state.replace(pipeline_state=data.replace(qvel=data.qvel.at[7].set(jnp.nan)))
    nxt = env_fns.step(broken, jnp.zeros(env.action_size))
    assert float(nxt.metrics["physics/reset_nan"]) == 1.0
    assert float(nxt.metrics["fell"]) == 0.0 and float(nxt.reward) == 0.0
    assert float(nxt.done) == 1.0 and float(nxt.info["truncation"]) == 1.0
    assert bool(jnp.all(jnp.isfinite(nxt.obs))) and bool(jnp.all(jnp.isfinite(nxt.pipeline_state.qvel)))
    assert int(nxt.info["steps"]) == 0  # restarted
    fine = env_fns.step(state, jnp.zeros(env.action_size))
    assert float(fine.metrics["physics/reset_nan"]) == 0.0


@pytest.mark.slow
def test_two_clip_library_draws_both_and_grades_each_env_against_its_own_clip(env, character):
    """Per-env motion state: a walk and a squat in one env; resets draw both clips by weight, and
    an env placed on either clip's reference scores ~1 against that clip and less against the other."""
    walk, squat = (load_clip_source(n, character) for n in ("slow_walk", "squat"))
    two = ImitationEnv(env.config, character, [walk, squat], weights=[0.25, 0.75])
    states = jax.jit(jax.vmap(two.reset))(jax.random.split(jax.random.PRNGKey(5), 400))
    clips = np.asarray(states.info["clip"])
    assert set(np.unique(clips)) == {0, 1}
    assert 0.18 < np.mean(clips == 0) < 0.32  # weights 1:3
    times = np.asarray(states.info["time"])
    assert times[clips == 1].max() <= float(two.spec.lib.duration[1])
    trans, reset_two = jax.jit(two.transition), jax.jit(two.reset_at)
    zero = jnp.zeros(two.action_size)
    for clip in (0, 1):
        own = reset_two(jax.random.PRNGKey(0), 0.6, clip)
        after = trans(own, zero)
        assert int(after.info["clip"]) == clip and float(after.reward) > 0.7
        # the same body state graded against the other clip
        other = own.replace(info=dict(own.info, clip=jnp.asarray(1 - clip, jnp.int32)))
        assert float(trans(other, zero).reward) < float(after.reward) - 0.1


def test_push_event_moves_the_root_the_same_way_on_mjx_and_mujoco_c(env):
    """env.events=push with a drawn force in [300, 600] N and a start jittered by up to 0.2 s: in
    the second interval a 0.2 s horizontal push on the root; the root speeds up along the push
    direction by about force x dt / mass, by the same amount on both backends."""
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.task import events

    cfg = apply_overrides(env.config, {"env.events": "push", "env.push_force_n": 300.0, "env.push_force_max_n": 600.0,
                                       "env.push_interval_s": 0.5, "env.push_interval_jitter_s": 0.2,
                                       "env.solver_iterations": 30, "env.ls_iterations": 30})
    pushed = ImitationEnv(cfg, env.character, env.clips)
    trans = jax.jit(pushed.transition)
    state = jax.jit(pushed.reset_at)(jax.random.PRNGKey(0), 0.3)
    seed = float(state.info["event_seed"])
    wrench = [events.push(cfg.env, k / 30, seed, env.model.nbody, np)[ROOT_BODY] for k in range(30)]
    pushing = [k for k in range(30) if np.any(wrench[k][:2] != 0)]
    first = pushing[0]  # the jittered start: 0.5 s to 0.7 s in
    assert 15 <= first <= 21 and pushing == list(range(first, first + 6))  # 0.2 s = 6 steps
    force = np.linalg.norm(wrench[first][:2])
    assert 300.0 <= force <= 600.0
    at = lambda steps: state.replace(info=dict(state.info, steps=jnp.asarray(steps, jnp.int32)))
    zero = jnp.zeros(env.action_size)
    # the step count changes nothing else in a control step far from the time limit
    mjx_pushed = np.asarray(trans(at(first), zero).pipeline_state.qvel[0:2])
    gain = mjx_pushed - np.asarray(trans(at(first - 1), zero).pipeline_state.qvel[0:2])
    along = gain @ wrench[first][:2] / force
    expected = force / 30 / 45.0  # force x dt / the humanoid's 45 kg
    assert 0.5 * expected < along < 1.7 * expected and np.linalg.norm(gain) < 1.2 * along

    cpu = CpuEnv(cfg, env.character, env.clips[0])
    q, v = (np.asarray(x) for x in (state.pipeline_state.qpos, state.pipeline_state.qvel))
    cpu.set_state(q, v, 0.3, steps=first, event_seed=seed)
    cpu.step(np.zeros(env.action_size))
    np.testing.assert_allclose(cpu.data.qvel[0:2], mjx_pushed, atol=0.02)


def test_a_getup_starting_on_its_back_is_no_fall(deepmimic_dir, character):
    """getup_faceup starts lying on its back: the root and chest (its fall-contact bodies) touch
    the floor because the reference does. That is no fall by default; under DeepMimic's plain rule
    (env.fall_ignores_reference_contacts=false) the episode ends at once. Standing, the same
    contact is a fall either way."""
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip, resolve_clip

    clip = load_clip(resolve_clip("getup_faceup", str(deepmimic_dir / "motions"), character.clip_prefix), character)
    for ignore in (True, False):
        config = make_config("cpu", {"env.action_mode": "residual", "env.fall_ignores_reference_contacts": ignore})
        env = CpuEnv(config, character, clip)
        env.reset_at(0.0)
        assert env.step(np.zeros(env.action_size)).fell != ignore
    walk = load_clip(resolve_clip("walk", str(deepmimic_dir / "motions"), character.clip_prefix), character)
    env = CpuEnv(make_config("cpu", {"env.action_mode": "residual"}), character, walk)
    env.reset_at(0.0)
    env.data.qpos[2] = 0.12  # the root dropped to the floor while the reference walks
    assert env.step(np.zeros(env.action_size)).fell
