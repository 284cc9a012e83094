"""Export, numpy policy and CPU playback: parity with the MJX env and the JAX policy, the file's
round trip, `mjxmimic play` end to end (and JAX-free), and sim-to-sim NR against MJX.

One cpu-preset env and run folder are built per module (the run holds a checkpoint of freshly
initialised, then randomised, parameters saved through mjxmimic.runs.checkpoint; no training)."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjxmimic.cli import main as cli_main
from mjxmimic.core import config as config_lib
from mjxmimic.core import quat
from mjxmimic.core.errors import UserError
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.envs.mjx_env import make_env
from mjxmimic.learn.ppo import TrainState, export_params, make_networks, make_policy_fn, make_trainer
from mjxmimic.motion import library as motion
from mjxmimic.portable import policy_file as policy_format
from mjxmimic.portable.playback import evaluate
from mjxmimic.portable.policy_numpy import NumpyPolicy
from mjxmimic.runs import checkpoint, export, folder

REPO = Path(__file__).resolve().parent.parent


# ---------------------------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def config():
    # A converged contact solve: with the cpu preset's 4 Newton iterations, MJX and MuJoCo C
    # stop at different unconverged solutions, and the physics (not playback) would differ.
    return config_lib.make_config("cpu", {"env.solver_iterations": 30, "env.ls_iterations": 30})


@pytest.fixture(scope="module")
def env(config):
    return make_env(config)


@pytest.fixture(scope="module")
def cpu_env(env, config):
    return CpuEnv(config, env.character, env.clips[0])


@pytest.fixture(scope="module")
def transition(env):
    return jax.jit(env.transition)


@pytest.fixture(scope="module")
def reset_at(env):
    return jax.jit(env.reset_at)


@pytest.fixture(scope="module")
def kinematics(env):
    return jax.jit(env.physics.init)


@pytest.fixture(scope="module")
def mjx_fns(reset_at, kinematics, transition):
    return reset_at, kinematics, transition


def _randomised_state(env, config, seed: int = 0) -> TrainState:
    """A TrainState of fresh parameters, the normaliser and the policy's mean head randomised so
    that every part of the exported function matters (actions of order 0.3, not ~0)."""
    from brax.training import types as brax_types

    trainer = make_trainer(env, config)
    params, opt_state, normalizer = trainer.init_learner(jax.random.PRNGKey(seed))
    rng = np.random.default_rng(seed)
    n = env.observation_size
    normalizer = normalizer.replace(mean=jnp.asarray(rng.normal(scale=0.3, size=n), jnp.float32),
                                    std=jnp.asarray(rng.uniform(0.5, 2.0, size=n), jnp.float32))
    layers = dict(params.policy["params"])
    last = f"hidden_{len(layers) - 1}"
    kernel = np.asarray(layers[last]["kernel"]).copy()
    kernel[:, : env.action_size] *= 30.0
    layers[last] = {"kernel": jnp.asarray(kernel), "bias": layers[last]["bias"]}
    params = params.replace(policy={**params.policy, "params": layers})
    return TrainState(params=params, optimizer_state=opt_state, normalizer=normalizer, env_state=None,
                      key=jax.random.PRNGKey(seed), env_steps=brax_types.UInt64(hi=0, lo=1234))


def _mjx_episodes(env, reset_at, transition, policy, starts):
    """NR episodes on MJX through the env's own transition (mjxmimic.runs.evaluate's counting: reward
    until a fall or a non-timeout done, divided by the horizon)."""
    act = jax.jit(policy)
    out = []
    for t0 in starts:
        state = reset_at(jax.random.PRNGKey(0), jnp.float32(t0))
        horizon = int(max(min(int(env.eval_horizon(jnp.float32(t0))), env.max_eval_horizon), 1))
        total = 0.0
        for k in range(horizon):
            state = transition(state, act(state.obs, jax.random.PRNGKey(0)))
            total += float(state.reward)
            ended = bool(state.done) and not bool(state.info["truncation"])
            if float(state.metrics["fell"]) > 0 or ended:
                break
        out.append(total / horizon)
    return np.array(out)


@pytest.fixture(scope="module")
def run(tmp_path_factory, env, config, reset_at, transition):
    """A cpu-preset run folder: config.json, one checkpoint, eval.json with the MJX NR of 4 episodes
    from the start times mjxmimic.runs.evaluate would draw for the run's eval seed."""
    run_dir = tmp_path_factory.mktemp("runs") / "cpu-run"
    run_dir.mkdir()
    config_lib.save(config, run_dir / "config.json")
    ts = _randomised_state(env, config)
    checkpoint.save(run_dir, ts, iterations=1, elapsed_seconds=1.5)
    params = export_params(ts)
    seed, n = config.run.seed + 1, 4
    starts = export.mjx_eval_start_times(seed, n, env.clip_duration)
    networks = make_networks(env.observation_size, env.action_size, config)
    per_episode = _mjx_episodes(env, reset_at, transition, make_policy_fn(networks, params), starts)
    (run_dir / "eval.json").write_text(json.dumps({"nr": float(per_episode.mean()), "episodes": n,
                                                   "fall_rate": 1.0, "samples": 1234}))
    return {"dir": run_dir, "ts": ts, "params": jax.tree_util.tree_map(np.asarray, params),
            "mjx_per_episode": per_episode, "starts": starts}


@pytest.fixture(scope="module")
def policy_file(run):
    return export.export_run(run["dir"])[0]


# ------------------------------------------------------------------------- observation parity


def _random_pose(env, rng, t, sigma):
    """The reference at t with every joint turned by ~sigma rad, random velocities."""
    qpos, qvel = motion.sample(env.spec.lib, 0, t)
    qpos, qvel = np.array(qpos, np.float64), np.array(qvel, np.float64)
    lay = env.spec.layout
    turn = quat.from_rotvec(rng.normal(scale=sigma, size=(len(lay.q_quat) - 1, 3)))
    qpos[lay.q_quat[1:]] = quat.mul(qpos[lay.q_quat[1:]], turn)
    qpos[lay.q_scalar[3:]] += rng.normal(scale=sigma, size=len(lay.q_scalar) - 3)
    qpos[3:7] = quat.mul(quat.from_rotvec(rng.normal(scale=sigma, size=3)), qpos[3:7])
    qvel += rng.normal(scale=1.0, size=qvel.shape)
    return qpos.astype(np.float32), qvel.astype(np.float32)


def _one_step_both(mjx_fns, cpu_env, qpos, qvel, t, action):
    reset_at, kinematics, transition = mjx_fns
    state = reset_at(jax.random.PRNGKey(0), jnp.float32(t))
    data = kinematics(jnp.asarray(qpos), jnp.asarray(qvel))
    nxt = transition(state.replace(pipeline_state=data), jnp.asarray(action, jnp.float32))
    cpu_env.set_state(qpos, qvel, t)
    step = cpu_env.step(action)
    return nxt, step


def test_observation_parity_on_random_states_in_the_air(env, cpu_env, mjx_fns):
    """Random poses, velocities and actions, lifted clear of the floor: one control step (PD
    substeps, kinematics, reward, done, observation) on MJX and on MuJoCo C agree."""
    rng = np.random.default_rng(1)
    worst = {"obs": 0.0, "reward": 0.0}
    for _ in range(8):
        t = float(rng.uniform(0, env.clip_duration))
        qpos, qvel = _random_pose(env, rng, t, sigma=0.4)
        qpos[2] += 1.0  # no contact: the two simulators differ only in arithmetic
        action = rng.uniform(-1, 1, env.action_size)
        nxt, step = _one_step_both(mjx_fns, cpu_env, qpos, qvel, t, action)
        assert nxt.obs.shape == step.obs.shape == (env.observation_size,)
        worst["obs"] = max(worst["obs"], float(np.max(np.abs(np.asarray(nxt.obs) - step.obs))))
        worst["reward"] = max(worst["reward"], abs(float(nxt.reward) - step.reward))
        assert bool(nxt.done) == step.done and bool(nxt.metrics["fell"]) == step.fell
        assert cpu_env.time == pytest.approx(float(nxt.info["time"]), abs=1e-7)
    assert worst["obs"] < 1e-3 and worst["reward"] < 1e-4, worst


def test_observation_parity_from_reference_states_on_the_ground(env, cpu_env, mjx_fns):
    """RSI states with the feet on the floor and small actions: one step agrees (with a converged
    contact solve; the feet touch the floor through sole spheres, which MJX and C treat alike)."""
    rng = np.random.default_rng(2)
    for _ in range(10):
        t = float(rng.uniform(0, env.clip_duration))
        qpos, qvel = (np.asarray(x, np.float32) for x in motion.sample(env.spec.lib, 0, t))
        action = rng.uniform(-0.1, 0.1, env.action_size)
        obs0 = cpu_env.reset_at(t)
        np.testing.assert_allclose(obs0, np.asarray(mjx_fns[0](jax.random.PRNGKey(0), jnp.float32(t)).obs), atol=1e-5)
        nxt, step = _one_step_both(mjx_fns, cpu_env, qpos, qvel, t, action)
        assert bool(nxt.done) == step.done
        np.testing.assert_allclose(step.obs, np.asarray(nxt.obs), atol=1e-3)
        assert step.reward == pytest.approx(float(nxt.reward), abs=1e-4)


def test_root_sync_at_a_new_cycle_matches(env, cpu_env, mjx_fns):
    """A character beside its reference crosses into a new cycle: both sides move the reference
    root under it alike (the root offset and the reward agree)."""
    t = env.clip_duration - 0.5 * env.control_dt
    qpos, qvel = (np.asarray(x, np.float32).copy() for x in motion.sample(env.spec.lib, 0, t))
    qpos[0:2] += np.array([0.3, -0.4], np.float32)
    nxt, step = _one_step_both(mjx_fns, cpu_env, qpos, qvel, t, np.zeros(env.action_size))
    np.testing.assert_allclose(cpu_env.motion.root_offset, np.asarray(nxt.info["root_offset"]), atol=1e-4)
    assert np.abs(cpu_env.motion.root_offset).max() > 0.25
    assert step.reward == pytest.approx(float(nxt.reward), abs=1e-4)


def test_fall_detection_matches(env, cpu_env, mjx_fns):
    t = 0.2
    qpos, qvel = (np.asarray(x, np.float32).copy() for x in motion.sample(env.spec.lib, 0, t))
    qpos[2] = 0.08  # lying face down: chest on the floor
    qpos[3:7] = quat.from_rotvec(np.array([0.0, np.pi / 2, 0.0]))
    nxt, step = _one_step_both(mjx_fns, cpu_env, qpos, qvel, t, np.zeros(env.action_size))
    assert step.fell and step.done and step.reward == 0.0
    assert bool(nxt.metrics["fell"]) and bool(nxt.done)


# ------------------------------------------------------------------------------ policy parity


@pytest.mark.parametrize("hidden", [(64, 64), (1024, 512)])
def test_numpy_policy_matches_the_jax_policy(hidden):
    obs_size, act_size = 227, 28
    cfg = config_lib.make_config("cpu", {"ppo.policy_hidden": ",".join(map(str, hidden))})
    networks = make_networks(obs_size, act_size, cfg)
    rng = np.random.default_rng(3)
    raw = networks.policy_network.init(jax.random.PRNGKey(3))
    # Brax's initial weights (lecun uniform), random biases and normaliser; observations drawn
    # from the normaliser's own statistics, so the network sees what training feeds it.
    policy = {name: {"kernel": np.asarray(layer["kernel"]),
                     "bias": rng.normal(scale=0.1, size=np.shape(layer["bias"])).astype(np.float32)}
              for name, layer in raw["params"].items()}
    mean = rng.normal(size=obs_size).astype(np.float32)
    std = rng.uniform(0.2, 3.0, size=obs_size).astype(np.float32)
    params = {"normalizer": {"mean": mean, "std": std}, "policy": policy}
    obs = (mean + std * rng.normal(scale=1.5, size=(256, obs_size))).astype(np.float32)
    jax_action = np.asarray(jax.jit(make_policy_fn(networks, params, deterministic=True))(
        jnp.asarray(obs), jax.random.PRNGKey(0)))
    np_action = NumpyPolicy.from_params(params)(obs)
    assert np_action.shape == jax_action.shape == (256, act_size)
    assert np.abs(np_action).max() > 0.5 and np.abs(np_action).min() < 0.05  # tanh over its range
    assert np.max(np.abs(np_action - jax_action)) <= 1e-5
    single = NumpyPolicy.from_params(params)(obs[0])
    np.testing.assert_allclose(single, np_action[0], atol=1e-12)


# ------------------------------------------------------------------------------------- export


def test_export_reads_the_checkpoint_like_export_params(run):
    params, meta = folder.load_policy_params(run["dir"])
    want = run["params"]
    for k in ("mean", "std"):
        np.testing.assert_array_equal(params["normalizer"][k], want["normalizer"][k])
    assert sorted(params["policy"]) == sorted(want["policy"])
    for name, layer in want["policy"].items():
        for k in ("kernel", "bias"):
            np.testing.assert_array_equal(params["policy"][name][k], layer[k])
    assert meta["checkpoint"] == 1234


def test_export_round_trip(run, policy_file, config, env):
    pf = policy_format.read(policy_file)
    assert policy_file == run["dir"] / "policy.npz"
    m = pf.manifest
    assert m["format"] == "mjxmimic-policy" and m["format_version"] == 1
    assert m["character"]["file"] == "humanoid.xml"
    assert m["character"]["sha256"] == env.character.sha256()
    assert pf.character_xml == env.character.xml_path.read_text()
    assert m["clip"]["name"] == config.clip.name and m["clip"]["loop"] is True
    assert m["control"]["physics_hz"] == 120 and m["control"]["substeps"] == 4
    assert m["control"]["control_hz"] == 30 and m["control"]["action_mode"] == config.env.action_mode
    assert m["observation"]["size"] == env.observation_size == sum(p["size"] for p in m["observation"]["layout"])
    assert [j["name"] for j in m["character"]["joints"]] == [j.name for j in env.character.joints]
    assert [j["kp"] for j in m["character"]["joints"]] == [j.kp for j in env.character.joints]
    assert m["policy"]["hidden_sizes"] == [64, 64]
    assert m["training"]["checkpoint"] == 1234 and m["training"]["eval"]["episodes"] == 4
    np.testing.assert_allclose(m["training"]["eval"]["start_times"], run["starts"])
    assert pf.config() == config
    # every array survives bit for bit
    want = run["params"]
    for k in ("mean", "std"):
        np.testing.assert_array_equal(pf.params["normalizer"][k], want["normalizer"][k])
    for name, layer in want["policy"].items():
        for k in ("kernel", "bias"):
            np.testing.assert_array_equal(pf.params["policy"][name][k], layer[k])
    clip = env.clips[0]
    np.testing.assert_array_equal(pf.clip_qpos, clip.qpos)
    np.testing.assert_array_equal(pf.clip_durations, clip.durations)
    assert set(m["arrays"]) == set(pf.arrays())
    # and writing what was read gives the same file contents
    again = policy_format.read(policy_format.write_npz(pf, policy_file.parent / "again.npz"))
    assert again.manifest == pf.manifest
    for key, value in pf.arrays().items():
        np.testing.assert_array_equal(again.arrays()[key], value)
    # the embedded character and clip are the run's
    character = pf.character()
    assert character.model.nq == env.character.model.nq and character.sha256() == env.character.sha256()
    assert pf.clip().loop == clip.loop and pf.clip().name == clip.name


def test_export_carries_the_value_network(run, policy_file, env, config):
    """The file's value network, run in numpy, is the run's JAX value network (normaliser
    included); an older file without it still plays and says what it lacks."""
    pf = policy_format.read(policy_file)
    assert pf.has_value() and pf.manifest["value"]["discount"] == config.ppo.discounting
    assert pf.manifest["value"]["hidden_sizes"] == list(config.ppo.value_hidden)
    ts = run["ts"]
    networks = make_networks(env.observation_size, env.action_size, config)
    obs = (np.asarray(ts.normalizer.mean) + np.asarray(ts.normalizer.std)
           * np.random.default_rng(5).normal(size=(64, env.observation_size))).astype(np.float32)
    want = np.asarray(jax.jit(networks.value_network.apply)(ts.normalizer, ts.params.value, jnp.asarray(obs)))
    got = pf.value()(obs)
    assert got.shape == (64,) and np.std(want) > 1e-3
    np.testing.assert_allclose(got, want, atol=1e-4)
    assert pf.value()(obs[0]) == pytest.approx(float(want[0]), abs=1e-4)
    old = dataclasses.replace(pf, params={k: v for k, v in pf.params.items() if k != "value"})
    old.manifest = {k: v for k, v in pf.manifest.items() if k != "value"}
    back = policy_format.read(policy_format.write_npz(old, policy_file.parent / "old.npz"))
    assert not back.has_value() and back.policy()(obs[0]).shape == (env.action_size,)
    with pytest.raises(UserError, match="lacks its value network.*re-export"):
        back.value()


def test_onnx_export_runs_the_same_function(run, tmp_path):
    onnx = pytest.importorskip("onnx")
    from onnx.reference import ReferenceEvaluator

    out, pf = export.export_run(run["dir"], tmp_path / "policy.onnx", fmt="onnx")
    model = onnx.load(str(out))
    obs = np.random.default_rng(4).normal(size=(16, 227)).astype(np.float32)
    action, value = ReferenceEvaluator(model).run(None, {"obs": obs})
    np.testing.assert_allclose(action, pf.policy()(obs), atol=1e-5)
    np.testing.assert_allclose(value[:, 0], pf.value()(obs), atol=1e-4)
    back = policy_format.read(out)
    assert back.manifest == pf.manifest
    for key, value in pf.arrays().items():
        np.testing.assert_array_equal(back.arrays()[key], value)


def test_mjx_start_times_are_those_of_mjxmimic_evaluate():
    sys.path.insert(0, str(Path(__file__).parent))
    from standin_env import StandInEnv

    from mjxmimic.runs.evaluate import rollout

    standin = StandInEnv(clip_duration=1.7)
    policy = lambda obs, key: jnp.zeros(obs.shape[:-1] + (standin.action_size,))
    acc = jax.jit(lambda k: rollout(standin, policy, k, 8))(jax.random.PRNGKey(11))
    np.testing.assert_array_equal(np.asarray(acc["start_time"], np.float32),
                                  export.mjx_eval_start_times(11, 8, 1.7))


def test_export_errors_are_one_line(tmp_path, capsys):
    assert cli_main(["export", str(tmp_path / "missing")]) == 2
    assert cli_main(["play", str(tmp_path / "missing.npz")]) == 2
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    assert cli_main(["play", str(tmp_path / "junk.npz")]) == 2
    np.savez_compressed(tmp_path / "whole.npz", weights=np.arange(4096.0))
    (tmp_path / "cut.npz").write_bytes((tmp_path / "whole.npz").read_bytes()[:200])  # a zip cut short
    assert cli_main(["play", str(tmp_path / "cut.npz")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4 and all(line.startswith("mjxmimic ") and "error:" in line for line in err), err


# ------------------------------------------------------------------------------------ playback


def _run_play(*args, env_vars=None):
    """`mjxmimic play ...` in a fresh interpreter that reports whether JAX was imported."""
    code = ("import sys; from mjxmimic.cli import main; rc = main(sys.argv[1:]); "
            "print('JAX_IMPORTED=' + str(any(m == 'jax' or m.startswith('jax.') for m in sys.modules)), "
            "file=sys.stderr); sys.exit(rc)")
    env = dict(os.environ, **(env_vars or {}))
    return subprocess.run([sys.executable, "-c", code, "play", *map(str, args)], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=120, check=False)


def test_play_cli_reports_nr_and_ratio_without_importing_jax(policy_file):
    result = _run_play(policy_file, "--episodes", "4", "--json")
    assert result.returncode == 0, result.stderr
    assert "JAX_IMPORTED=False" in result.stderr, result.stderr
    out = json.loads(result.stdout)
    assert 0.0 <= out["nr"] <= 1.0 and out["episodes"] == 4
    assert out["mjx_nr"] > 0 and out["ratio"] == pytest.approx(out["nr"] / out["mjx_nr"])
    assert out["starts"].startswith("the MJX evaluation's")
    assert out["simulator"].startswith("mujoco ") and "(CPU, mj_step)" in out["simulator"]
    for key in ("fall_rate", "survival_s", "pose_error_rad", "end_effector_error_m", "steps_per_s"):
        assert key in out


def test_play_solves_to_convergence_unless_told(policy_file):
    """Playback lets MuJoCo's Newton solve run to its own limits (or the training's, if higher), as
    MJX-Warp's converges within the training's 4 iterations; --solver-iterations sets both limits."""
    default = json.loads(_run_play(policy_file, "--episodes", "1", "--json").stdout)
    assert default["solver_iterations"] == list(config_lib.PLAYBACK_SOLVER_ITERATIONS)
    told = json.loads(_run_play(policy_file, "--episodes", "1", "--json", "--solver-iterations", "4").stdout)
    assert told["solver_iterations"] == [4, 4] and told["nr"] != default["nr"]
    bad = _run_play(policy_file, "--solver-iterations", "0")
    assert bad.returncode == 2 and "--solver-iterations 0: must be at least 1" in bad.stderr, bad.stderr
    higher = config_lib.make_config("cpu", {"env.solver_iterations": 300, "env.ls_iterations": 60})
    assert config_lib.playback_config(higher).env.solver_iterations == 300
    assert config_lib.playback_config(higher).env.ls_iterations == 60


def test_play_push_test_without_jax(policy_file):
    result = _run_play(policy_file, "--push", "--trials", "2", "--json")
    assert result.returncode == 0, result.stderr
    assert "JAX_IMPORTED=False" in result.stderr, result.stderr
    out = json.loads(result.stdout)
    assert out["push_trials"] == 2 and out["push_forward_n"] >= 0 and out["push_sideways_n"] >= 0
    assert out["push_forward_tried"][0][0] == 0.0  # the search starts unpushed
    assert "(CPU, mj_step)" in out["simulator"]
    alone = json.loads(_run_play(policy_file, "--push", "--trials", "2", "--json", "--workers", "1").stdout)
    assert alone["push_forward_tried"] == out["push_forward_tried"]  # workers change nothing but the time
    assert alone["push_sideways_tried"] == out["push_sideways_tried"]
    bad = _run_play(policy_file, "--push", "--workers", "0")
    assert bad.returncode == 2 and "--workers 0: must be at least 1" in bad.stderr, bad.stderr


def test_play_on_a_grid_of_starts(policy_file):
    """--grid: a start every SECONDS over the clip, whose falls come grouped in runs of starts."""
    out = json.loads(_run_play(policy_file, "--grid", "0.2", "--json").stdout)
    duration = policy_format.read(policy_file).clip().duration
    np.testing.assert_allclose(out["start_times"], np.arange(0.0, duration, 0.2), atol=1e-6)
    assert out["starts"] == "a grid over the clip, every 0.2 s" and out["episodes"] == len(out["start_times"])
    assert sum(n for _, _, n in out["fall_windows"]) == round(out["fall_rate"] * out["episodes"])
    bad = _run_play(policy_file, "--grid", "0.2", "--episodes", "3")
    assert bad.returncode == 2 and "--grid sets the start times itself" in bad.stderr, bad.stderr
    assert _run_play(policy_file, "--grid", "0").returncode == 2


def test_play_text_output_and_run_folder(run, policy_file, capsys):
    assert cli_main(["play", str(run["dir"]), "--episodes", "2", "--seed", "5"]) == 0
    out = capsys.readouterr().out
    assert "sim-to-sim NR (CPU)" in out and "ratio CPU / MJX" in out and "seed 5" in out


def test_viewer_without_a_display_is_a_clear_error(policy_file):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run([sys.executable, "-m", "mjxmimic.cli", "play", str(policy_file), "--viewer"],
                            cwd=REPO, env=env, capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--viewer needs a display" in lines[0], result.stderr


def test_sim_to_sim_nr_on_the_same_starts(run, policy_file):
    """The exported file, played on MuJoCo C from the MJX evaluation's start times, scores about
    what the (randomised) policy scored on MJX. Only a coarse check: this policy falls within
    ~0.6 s, and MJX's plane-box contacts (see the ground parity test) shift fall times by a few
    steps; exactness is what the parity tests above prove."""
    pf = policy_format.read(policy_file)
    cpu = CpuEnv(pf.config(), pf.character(), pf.clip())
    result = evaluate(cpu, pf.policy(), pf.manifest["training"]["eval"]["start_times"])
    np.testing.assert_allclose(result["start_times"], run["starts"])
    per_mjx = run["mjx_per_episode"]
    assert np.all(per_mjx > 0) and np.all(np.array(result["per_episode_nr"]) > 0)
    assert 0.7 < result["nr"] / per_mjx.mean() < 1.4, (result["per_episode_nr"], per_mjx)


@pytest.mark.slow
def test_eval_of_the_exported_file_matches_the_run(run, policy_file, capsys):
    """`mjxmimic eval POLICY.npz` measures on MJX what `mjxmimic eval RUN` measures of the same
    checkpoint (the same episodes: the run's evaluation seed), the network in jax.numpy."""
    results = []
    for source in (run["dir"], policy_file):
        assert cli_main(["eval", str(source), "--episodes", "4", "--json"]) == 0
        results.append(json.loads(capsys.readouterr().out))
    from_run, from_file = results
    assert from_file["episodes"] == 4 and from_file["policy"] == str(policy_file)
    assert from_file["simulator"] == from_run["simulator"] and "(impl jax, cpu)" in from_run["simulator"]
    for key in ("nr", "nr_paper", "fall_rate", "survival_s"):
        assert from_file[key] == pytest.approx(from_run[key], abs=1e-4), key


@pytest.mark.slow
def test_push_test_of_the_exported_file_matches_the_run(run, policy_file, capsys):
    """`mjxmimic eval POLICY.npz --push` grades on MJX what `eval RUN --push` grades of the same
    checkpoint; only the run folder keeps the result (push.json)."""
    results = []
    for source in (run["dir"], policy_file):
        assert cli_main(["eval", str(source), "--push", "--trials", "2", "--json"]) == 0
        results.append(json.loads(capsys.readouterr().out))
    from_run, from_file = results
    assert from_file["policy"] == str(policy_file) and "checkpoint" in from_run
    assert from_file["simulator"] == from_run["simulator"] and "(impl jax, cpu)" in from_run["simulator"]
    for key in ("push_forward_n", "push_sideways_n"):
        assert from_file[key] == pytest.approx(from_run[key], abs=10.0), key  # one bisection step
    assert json.loads((run["dir"] / "push.json").read_text()) == from_run  # the file's grade wrote nothing


def test_eval_of_a_policy_file_errors_are_one_line(tmp_path, policy_file, capsys):
    for push in ([], ["--push"]):
        assert cli_main(["eval", str(tmp_path / "missing.npz"), *push]) == 2
        err = capsys.readouterr().err.strip()
        assert "missing.npz: policy file not found" in err and len(err.splitlines()) == 1
        assert cli_main(["eval", str(policy_file), "--checkpoint", "best", *push]) == 2
        assert "--checkpoint is for run folders" in capsys.readouterr().err


def test_cpu_episode_counts_like_the_evaluation(cpu_env):
    """Zero absolute targets on a looping clip: the horizon is the env's episode length in steps
    (600 at 20 s), NR is reward / horizon, a fall ends the episode and scores 0 after it."""
    horizon = cpu_env.max_steps
    assert cpu_env.eval_horizon(0.3) == horizon == cpu_env.max_eval_horizon
    zero = lambda obs: np.zeros(cpu_env.character.action_size)
    ep = cpu_env.episode(zero, 0.3)
    assert ep["failed"] and ep["steps"] < horizon  # absolute zero targets: the humanoid falls
    assert ep["nr"] == pytest.approx(ep["reward"] / horizon)
