"""Terrain (issue 16): the course description, its scene, heightmap, RSI, the gap fall, the
heightmap policy's portable forward pass."""

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from mjxmimic.core import terrain as T
from mjxmimic.core.config import make_config


@pytest.mark.parametrize("kind", ["gaps", "beam", "stairs", "mixed"])
def test_height_numpy_equals_jax_and_courses_are_sane(kind):
    t = T.generate(kind, seed=3, difficulty=0.7, lanes=3, length=12.0)
    xy = np.random.default_rng(0).uniform([-2, -2], [16, 8], (500, 2)).astype(np.float32)
    h_np = T.height(t.boxes, t.depth, xy, np)
    h_jax = np.asarray(jax.jit(lambda p: T.height(t.boxes, t.depth, p, jnp))(jnp.asarray(xy)))
    np.testing.assert_allclose(h_np, h_jax, atol=1e-6)
    assert h_np.min() >= -t.depth and h_np.max() <= 1.5
    # every lane's start pad is flat ground, and the course goes on past its end
    for lane in range(t.lanes):
        pad = np.stack([np.linspace(-1.9, -0.1, 20), np.full(20, lane * t.lane_width)], -1)
        assert np.all(T.height(t.boxes, t.depth, pad, np) == 0.0)
        assert T.height(t.boxes, t.depth, np.array([12.5, lane * t.lane_width]), np) >= 0.0
    # the same seed gives the same course, another seed another one
    assert np.array_equal(T.generate(kind, seed=3, difficulty=0.7, lanes=3, length=12.0).boxes, t.boxes)
    assert not np.array_equal(T.generate(kind, seed=4, difficulty=0.7, lanes=3, length=12.0).boxes, t.boxes)


def test_height_is_the_highest_box_and_compiles_without_a_reduction():
    t = T.generate("stairs", seed=1, difficulty=0.5, lanes=4, length=40.0)  # ~200 boxes
    xy = np.random.default_rng(1).uniform([-2, -2], [45, 11], (2000, 2)).astype(np.float32)
    b = t.boxes
    inside = (np.abs(xy[:, None, 0] - b[:, 0]) <= b[:, 2]) & (np.abs(xy[:, None, 1] - b[:, 1]) <= b[:, 3])
    np.testing.assert_array_equal(T.height(b, t.depth, xy, np), np.where(inside, b[:, 4], -t.depth).max(-1))
    # an XLA reduction over (points, boxes) took minutes to compile on the GPU: keep it elementwise
    jaxpr = str(jax.make_jaxpr(lambda p: T.height(b, t.depth, p, jnp))(jnp.asarray(xy)))
    assert "reduce_max" not in jaxpr and "argmax" not in jaxpr


def test_gaps_have_gaps_and_stairs_climb():
    line = np.stack([np.linspace(0, 10, 1001), np.zeros(1001)], -1)
    gaps = T.generate("gaps", difficulty=1.0, lanes=1, length=10.0)
    assert (T.height(gaps.boxes, gaps.depth, line, np) == -gaps.depth).mean() > 0.2
    stairs = T.generate("stairs", difficulty=1.0, lanes=1, length=10.0)
    h = T.height(stairs.boxes, stairs.depth, line, np)
    step = np.abs(np.diff(h))
    assert h.max() >= 0.8 and np.all(np.isclose(step, 0.0) | np.isclose(step, 0.2))


def test_heightmap_in_heading_frame():
    t = T.generate("stairs", difficulty=0.5, lanes=2, length=8.0)
    offsets = T.grid_offsets(5, 4, 0.25, 0.5)
    assert offsets.shape == (20, 2) and np.allclose(offsets.mean(0), [0.5, 0.0])
    root, yaw = np.array([1.3, 0.2, 1.1], np.float32), 0.7
    hm = T.heightmap(t.boxes, t.depth, offsets, root, yaw, np)
    c, s = np.cos(yaw), np.sin(yaw)
    world = root[:2] + offsets @ np.array([[c, s], [-s, c]])
    np.testing.assert_allclose(hm, T.height(t.boxes, t.depth, world, np) - root[2], atol=1e-6)
    hm_jax = T.heightmap(t.boxes, t.depth, jnp.asarray(offsets), jnp.asarray(root), yaw, jnp)
    np.testing.assert_allclose(hm, np.asarray(hm_jax), atol=1e-5)


def _dropped_on_step(character, impl):
    """The humanoid dropped onto a 0.3 m box for 0.5 s: (lowest body centre, root z, contacts)."""
    from mjxmimic.core.scene import build_scene

    step = T.Terrain(boxes=np.array([[0, 0, 1.0, 1.0, 0.3]], np.float32), depth=1.0, lanes=1,
                     lane_width=3.0, length=1.0)
    scene = build_scene(character, 120, 4, 4, step)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[2] += 0.3 + 0.05
    if impl == "c":
        for _ in range(60):
            mujoco.mj_step(m, d)
        return d.xipos[1:, 2].min(), d.qpos[2], d.sensordata[scene.contact_adr].sum()
    from mujoco import mjx

    mx, dx = mjx.put_model(m, impl="jax"), mjx.put_data(m, d, impl="jax")
    dx = jax.jit(lambda x: jax.lax.fori_loop(0, 60, lambda i, y: mjx.step(mx, y), x))(dx)
    return float(dx.xipos[1:, 2].min()), float(dx.qpos[2]), float(dx.sensordata[scene.contact_adr].sum())


@pytest.mark.parametrize("impl", ["c", pytest.param("jax", marks=pytest.mark.slow)])  # jax: 20 s to compile
def test_humanoid_rests_on_a_step(character, impl):
    lowest, root_z, contacts = _dropped_on_step(character, impl)
    assert lowest > 0.3 and root_z > 0.3 + 0.7  # on the step, not through it
    assert contacts >= 1  # the any-contact sensors see the box


def test_terrain_env_rsi_heightmap_and_gap_fall(character):
    """MuJoCo C env (numpy step): RSI puts the root on the start pad above the ground; the
    observation ends with the heightmap; a root dropped into a gap ends the episode as a fall."""
    from mjxmimic.envs import step as step_lib
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.physics.cpu import CpuPhysics
    from mjxmimic.task import termination

    config = make_config("cpu", {"terrain.kind": "gaps", "terrain.difficulty": "1.0", "task.name": "heading",
                                 "terrain.heightmap_shape": "6,5"})
    clips = [load_clip_source("slow_walk", character)]
    scene, spec = step_lib.build(config, character, clips, np)
    physics = CpuPhysics(scene, spec.layout, config.env.physics_hz // config.env.control_hz, config.env.torque_limit)
    for seed in (0.05, 0.3, 0.55, 0.99):
        state, motion, obs = step_lib.reset(spec, physics, 0, 0.4, seed)
        qpos, _ = physics.qpos_qvel(state)
        lane = int(seed * config.terrain.lanes)
        assert -T.START_PAD_M < qpos[0] < 0 and qpos[1] == pytest.approx(lane * config.terrain.lane_width_m)
        assert qpos[2] > 0.7 and abs(obs[-30:] + qpos[2]).max() < 0.3  # ground at 0 under the pad
        assert obs.shape == (spec.observation_size,) and spec.observation_size == 227 + 3 + 30
    terms = termination.evaluation_list(True, terrain=True)
    assert "pit" in terms
    # a root sinking into the first gap (x where the height is -depth) fails
    xs = np.linspace(0, 5, 501)
    gap_x = xs[T.height(spec.terrain.boxes, spec.terrain.depth, np.stack([xs, np.zeros_like(xs)], -1), np) < 0][0]
    state, motion, _ = step_lib.reset(spec, physics, 0, 0.4, 0.05)
    qpos, qvel = physics.qpos_qvel(state)
    qpos = qpos.copy()
    qpos[0:3] = [gap_x + 0.15, 0.0, -1.0]
    state = physics.init(qpos, qvel)
    out = step_lib.control_step(spec, physics, state, motion, np.zeros(spec.action_size), terms)
    assert out.failed and out.metrics["fell"] == 1.0


@pytest.mark.parametrize("shape,size,stride", [((16, 16, 1), 4, 2), ((8, 8, 16), 3, 2), ((4, 4, 32), 3, 1),
                                               ((7, 9, 3), 4, 2)])
def test_patch_conv_is_flax_conv(shape, size, stride):
    """The encoder's convolution as a matrix product over patches: linen.Conv's parameters and values."""
    from flax import linen

    from mjxmimic.learn.networks import PatchConv

    x = jax.random.normal(jax.random.PRNGKey(0), (5, *shape))
    conv = linen.Conv(6, (size, size), strides=(stride, stride), padding="SAME")
    params = conv.init(jax.random.PRNGKey(1), x)
    params = jax.tree_util.tree_map(lambda p: p + 0.1, params)  # a bias that is not zero
    patch = PatchConv(6, size, stride)
    assert jax.tree_util.tree_map(jnp.shape, patch.init(jax.random.PRNGKey(1), x)) == \
        jax.tree_util.tree_map(jnp.shape, params)
    np.testing.assert_allclose(patch.apply(params, x), conv.apply(params, x), atol=1e-5)


def test_heightmap_policy_numpy_equals_jax():
    from brax.training.acme import running_statistics

    from mjxmimic.learn import networks
    from mjxmimic.learn.networks import init_output_layer
    from mjxmimic.portable.policy_numpy import HEIGHTMAP_STRIDES, NumpyPolicy, NumpyValue

    assert HEIGHTMAP_STRIDES == tuple(s for _, _, s in networks.CONV_LAYERS)
    obs_size, act, shape = 40 + 7 * 9, 5, (7, 9)
    nets = networks.make_heightmap_networks(obs_size, act, (32, 16), (32,), shape, running_statistics.normalize,
                                            0.001)
    params = nets.policy_network.init(jax.random.PRNGKey(1))
    params = init_output_layer(params, act, 0.3, 0.001)
    assert set(params["params"]) == {"conv_0", "conv_1", "conv_2", "encoder", "hidden_0", "hidden_1", "hidden_2"}
    value = nets.value_network.init(jax.random.PRNGKey(2))
    rng = np.random.default_rng(0)
    mean, std = rng.normal(size=obs_size).astype(np.float32), rng.uniform(0.5, 2, obs_size).astype(np.float32)
    normalizer = running_statistics.NestedMeanStd(mean=jnp.asarray(mean), std=jnp.asarray(std))
    obs = rng.normal(size=(4, obs_size)).astype(np.float32)
    assert nets.value_network.apply(normalizer, value, jnp.asarray(obs)).shape == (4,)
    logits = np.asarray(nets.policy_network.apply(normalizer, params, jnp.asarray(obs)))
    pol = NumpyPolicy.from_params({"normalizer": {"mean": mean, "std": std},
                                   "policy": jax.tree_util.tree_map(np.asarray, dict(params["params"]))}, shape)
    np.testing.assert_allclose(pol.logits(obs), logits, atol=1e-5)
    # the heightmap matters: a different map, a different action
    bumped = obs.copy()
    bumped[:, -5] += 3.0
    assert not np.allclose(pol.logits(bumped), pol.logits(obs))
    # the value network reads the heightmap through an encoder of its own
    val = NumpyValue({"normalizer": {"mean": mean, "std": std},
                      "value": jax.tree_util.tree_map(np.asarray, dict(value["params"]))}, shape)
    want = np.asarray(nets.value_network.apply(normalizer, value, jnp.asarray(obs)))
    np.testing.assert_allclose(val(obs), want, atol=1e-5)
    assert not np.allclose(val(bumped), val(obs))


def test_onnx_export_of_a_terrain_policy_runs_its_encoders(character, tmp_path):
    """The ONNX graph of a terrain policy (conv encoders in policy and value) computes what the
    numpy forward pass does, and reading it back gives the npz file's arrays."""
    onnx = pytest.importorskip("onnx")
    from onnx.reference import ReferenceEvaluator

    from mjxmimic.learn import networks
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.portable import policy_file, policy_onnx

    config = make_config("cpu", {"terrain.kind": "gaps", "task.name": "heading"})
    clip = load_clip_source("slow_walk", character)
    obs_size = sum(p["size"] for p in policy_file.observation_layout(character, config, [clip.name]))
    nets = networks.make_networks(obs_size, character.action_size, config)
    rng = np.random.default_rng(3)
    params = {"normalizer": {"mean": rng.normal(size=obs_size).astype(np.float32),
                             "std": rng.uniform(0.5, 2, obs_size).astype(np.float32)},
              "policy": jax.tree_util.tree_map(np.asarray, dict(nets.policy_network.init(jax.random.PRNGKey(1))["params"])),
              "value": jax.tree_util.tree_map(np.asarray, dict(nets.value_network.init(jax.random.PRNGKey(2))["params"]))}
    pf = policy_file.make_policy_file(config, character, clip, params)
    assert pf.policy().encoder and pf.value().encoder
    path = policy_onnx.write_onnx(pf, tmp_path / "terrain.onnx")
    obs = rng.normal(size=(8, obs_size)).astype(np.float32)
    action, value = ReferenceEvaluator(onnx.load(str(path))).run(None, {"obs": obs})
    np.testing.assert_allclose(action, pf.policy()(obs), atol=1e-5)
    np.testing.assert_allclose(value[:, 0], pf.value()(obs), atol=1e-4)
    back = policy_onnx.read_onnx(path)
    for key, array in pf.arrays().items():
        np.testing.assert_array_equal(back.arrays()[key], array)


@pytest.mark.slow
def test_cpu_training_on_terrain_exports_and_replays(tmp_path, capsys):
    """Train (cpu preset, heading task, dense gaps), export, and replay on MuJoCo C: the policy
    file carries the course and the heightmap encoder."""
    import json

    from mjxmimic import cli

    run = tmp_path / "run"
    assert cli.main(["train", "--preset", "cpu", "--terrain", "gaps", "--task", "heading", "--out", str(run),
                     "--set", "run.total_samples=6144", "--set", "run.eval_every=3072",
                     "--set", "run.checkpoint_every=3072", "--set", "run.eval_episodes=4",
                     "--set", "terrain.lanes=1", "--set", "terrain.length_m=6"]) == 0  # few boxes: impl='jax' tests them all
    assert json.loads((run / "config.json").read_text())["terrain"]["kind"] == "gaps"
    assert cli.main(["export", str(run)]) == 0
    capsys.readouterr()
    assert cli.main(["play", str(run / "policy.npz"), "--episodes", "2", "--json"]) == 0
    played = json.loads(capsys.readouterr().out)
    assert 0.0 <= played["nr"] <= 1.0


def test_cpu_playback_reports_course_distance_and_success(character):
    """CPU playback (MuJoCo C, the numpy step) on a course: every episode starts on the pad, the
    summary has the course distance and success beside NR; a policy-free humanoid falls soon."""
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.portable.playback import evaluate

    config = make_config("cpu", {"terrain.kind": "stairs", "task.name": "heading", "terrain.length_m": "3"})
    env = CpuEnv(config, character, [load_clip_source("slow_walk", character)])
    out = evaluate(env, lambda obs: np.zeros(env.action_size), [0.1, 0.5])
    assert {"nr", "nr_paper", "course_distance_m", "course_success_rate"} <= set(out)
    assert -0.5 < out["course_distance_m"] < 3.0 and out["course_success_rate"] == 0.0


def test_graded_reference_stands_on_the_step_under_the_character(character):
    from mjxmimic.envs import step as step_lib
    from mjxmimic.motion import library as motion_lib
    from mjxmimic.motion.clip import load_clip_source

    config = make_config("cpu", {"terrain.kind": "stairs", "task.name": "heading", "terrain.difficulty": "1.0"})
    _, spec = step_lib.build(config, character, [load_clip_source("slow_walk", character)], np)
    ref_qpos, ref_qvel = motion_lib.sample(spec.lib, 0, np.float32(0.3), np)
    sim = ref_qpos.copy()
    xs = np.linspace(0, 6, 601)
    line = T.height(spec.terrain.boxes, spec.terrain.depth, np.stack([xs, np.zeros_like(xs)], -1), np)
    top_x = xs[np.argmax(line)]
    for x, lift in ((-1.0, 0.0), (top_x, line.max())):
        sim[0:2] = [x, 0.0]
        graded, _ = step_lib.graded_reference(spec, ref_qpos, ref_qvel, sim, np.zeros(2), np)
        assert graded[2] == pytest.approx(ref_qpos[2] + lift, abs=1e-5) and graded[0] == pytest.approx(x)
