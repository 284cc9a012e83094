"""Composite policies (issue 14, parts 4 and 5): the gate's math, compose's checks, the file's round
trip, the knock-down and recovery rule, CPU play without JAX, and the gate on MJX against the CPU's.
Random-weight experts (as tests/test_skills.py), no training."""

import dataclasses
import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mjxmimic import cli
from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.envs import composite as gate_lib
from mjxmimic.envs import entry as entry_lib
from mjxmimic.envs import start_bank
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.motion import library as motion_lib
from mjxmimic.motion.clip import load_clip_source
from mjxmimic.portable import composite, policy_file
from mjxmimic.task import recovery

REPO = Path(__file__).resolve().parent.parent


def _expert(character, clip, seed: int, observations: str = "phase,root_height,bodies", still: bool = False,
            overrides: dict | None = None, value: bool = True):
    """A policy file of random weights with a value network; `still`: zero actions (the PD tracks
    the reference: residual targets)."""
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.action_scale": 0.1,
                                            "env.observations": observations, **(overrides or {})})
    obs = CpuEnv(config, character, clip).observation_size
    rng = np.random.default_rng(seed)

    def net(sizes, scale):
        return {f"hidden_{i}": {"kernel": rng.normal(scale=scale / np.sqrt(a), size=(a, b)).astype(np.float32),
                                "bias": np.zeros(b, np.float32)} for i, (a, b) in enumerate(itertools.pairwise(sizes))}

    params = {"normalizer": {"mean": np.zeros(obs, np.float32), "std": np.ones(obs, np.float32)},
              "policy": net([obs, 32, 2 * character.action_size], 0.0 if still else 0.1)}
    if value:
        params["value"] = net([obs, 32, 1], 1.0)
    pf = policy_file.make_policy_file(config, character, clip, params)
    return pf


@pytest.fixture(scope="module")
def clips(character):
    squat = dataclasses.replace(load_clip_source("squat", character), loop=False)  # a one-shot skill, as a getup
    return {"slow_walk": load_clip_source("slow_walk", character), "squat": squat}


@pytest.fixture(scope="module")
def expert_files(tmp_path_factory, character, clips):
    folder = tmp_path_factory.mktemp("experts")
    out = {}
    for seed, (name, clip) in enumerate(clips.items()):
        pf = _expert(character, clip, seed)
        out[name] = policy_file.write_npz(pf, folder / f"{name}.npz")
    return out


@pytest.fixture(scope="module")
def composite_file(expert_files):
    experts = [policy_file.read(p) for p in expert_files.values()]
    return composite.write(composite.compose(experts), expert_files["slow_walk"].parent / "composite.npz")


# --------------------------------------------------------------------------------- the gate's math


def test_softmax_with_a_temperature():
    v = np.array([1.0, 2.0, 0.5])
    allowed = np.ones(3, bool)
    p = gate_lib.probabilities(v, 0.3, allowed, np)
    want = np.exp(v / 0.3) / np.exp(v / 0.3).sum()
    np.testing.assert_allclose(p, want, rtol=1e-5)
    hot, cold = gate_lib.probabilities(v, 3.0, allowed, np), gate_lib.probabilities(v, 0.05, allowed, np)
    assert hot.max() < p.max() < cold.max() and cold[1] > 0.999  # colder: surer of the best
    np.testing.assert_array_equal(gate_lib.probabilities(v, 0.0, allowed, np), [0, 1, 0])  # arg max
    shut = gate_lib.probabilities(v, 0.3, np.array([True, False, True]), np)
    assert shut[1] == 0 and shut.sum() == pytest.approx(1.0) and shut[0] > shut[2]
    np.testing.assert_array_equal(gate_lib.probabilities(v, 0.0, np.array([True, False, True]), np), [1, 0, 0])


def test_sampling_is_the_inverse_cdf_and_never_picks_the_impossible():
    p = np.array([0.2, 0.0, 0.5, 0.3], np.float32)
    assert [int(gate_lib.sample(p, u, np)) for u in (0.0, 0.19, 0.21, 0.69, 0.71, 0.999999)] == [0, 0, 2, 2, 3, 3]
    u = np.random.default_rng(0).uniform(size=20000)
    counts = np.bincount([int(gate_lib.sample(p, x, np)) for x in u], minlength=4) / len(u)
    np.testing.assert_allclose(counts, p, atol=0.015)
    assert int(gate_lib.sample(np.array([0.0, 1.0, 0.0]), 0.0, np)) == 1
    assert int(gate_lib.sample(np.array([1.0, 0.0]), 1.0, np)) == 0


def test_the_gate_math_is_the_same_in_jax():
    import jax.numpy as jnp

    rng = np.random.default_rng(1)
    for _ in range(20):
        v = rng.normal(scale=3, size=4).astype(np.float32)
        allowed = rng.uniform(size=4) > 0.3
        allowed[rng.integers(4)] = True
        u = np.float32(rng.uniform())
        for t in (0.0, 0.3):
            p_np = gate_lib.probabilities(v, t, allowed, np)
            p_jx = np.asarray(gate_lib.probabilities(jnp.asarray(v), t, jnp.asarray(allowed), jnp))
            np.testing.assert_allclose(p_np, p_jx, atol=1e-6)
            assert int(gate_lib.sample(p_np, u, np)) == int(gate_lib.sample(jnp.asarray(p_jx), u, jnp))


@pytest.fixture(scope="module")
def player(composite_file):
    return composite.Player(composite.read(composite_file), temperature=0.0)


def test_no_immediate_repeat_of_a_finished_one_shot_expert(player):
    env = player.env
    getup = 1
    favour = lambda obs: np.array([0.0, 10.0])  # the getup's value is far higher
    env.reset_at(1.0, clip=getup)
    qpos, qvel = env.data.qpos.copy(), env.data.qvel.copy()
    d = gate_lib.decide(env.spec, player.gate, env.physics, qpos, qvel, env.motion, favour, 0.5)
    assert int(d.choice) == getup and float(d.times[getup]) == pytest.approx(1.0)  # it goes on
    end = float(env.clip_durations[getup])
    env.reset_at(end, clip=getup)
    d = gate_lib.decide(env.spec, player.gate, env.physics, env.data.qpos.copy(), env.data.qvel.copy(),
                        env.motion, favour, 0.5)
    assert int(d.choice) == 0 and d.probabilities[getup] == 0  # finished: not again at once
    env.motion = gate_lib.switch(env.spec, env.motion, d, env.data.qpos.copy(), np)
    d = gate_lib.decide(env.spec, player.gate, env.physics, env.data.qpos.copy(), env.data.qvel.copy(),
                        env.motion, favour, 0.5)
    assert int(d.choice) == getup and float(d.times[getup]) == 0.0  # a step later: allowed, from its start


def test_entry_times(player):
    """Each expert enters at the time whose reference pose is the character's (here the reference
    itself, on the grid), a one-shot expert as a looping one."""
    env = player.env
    dt = env.control_dt
    def features(clip, t):
        return entry_lib.pose_features(env.physics.kinematics(*motion_lib.sample(env.spec.lib, clip, np.float32(t))), np)

    for clip in (0, 1):
        for k in (3, 17, 30):
            env.reset_at(k * dt, clip=clip)
            kin = env.physics.kinematics(env.data.qpos, env.data.qvel)
            times = entry_lib.nearest_times(player.gate.entry, kin, np)
            # that time, or one whose reference pose is the same (a clip may hold a pose a while)
            np.testing.assert_allclose(features(clip, times[clip]), features(clip, k * dt), atol=1e-4)
            assert clip == 1 or times[clip] == pytest.approx(k * dt, abs=1e-5)


def test_switching_moves_the_reference_under_the_character(player):
    env = player.env
    env.reset_at(0.4, clip=0)
    env.data.qpos[0:2] += [2.0, -1.0]
    d = gate_lib.decide(env.spec, player.gate, env.physics, env.data.qpos.copy(), env.data.qvel.copy(), env.motion,
                        lambda obs: np.array([0.0, 5.0]), 0.1)
    motion = gate_lib.switch(env.spec, env.motion, d, env.data.qpos.copy(), np)
    assert int(motion.clip) == 1 and float(motion.time) == float(d.times[1])
    ref, _ = motion_lib.sample(env.spec.lib, 1, np.float32(d.times[1]))
    np.testing.assert_allclose(motion_lib.shift_root(ref, motion.root_offset)[0:2], env.data.qpos[0:2], atol=1e-6)


def test_each_expert_observes_its_own_clip_phase(player):
    env = player.env
    env.reset_at(0.7, clip=0)
    kin = env.physics.kinematics(env.data.qpos, env.data.qvel)
    obs = gate_lib.expert_observations(env.spec, kin, np.array([0.7, 1.5], np.float32), np)
    durations = env.clip_durations
    assert obs[0, 0] == pytest.approx(0.7 / durations[0], abs=1e-6) and obs[1, 0] == pytest.approx(1.5 / durations[1])
    np.testing.assert_array_equal(obs[0, 1:], obs[1, 1:])  # the rest is the one character's state
    single = CpuEnv(env.config, env.character, env.clips[0]).reset_at(0.7)
    np.testing.assert_allclose(obs[0], single, atol=1e-6)  # what the expert saw in training


# ------------------------------------------------------------------------------ compose and files


def test_compose_round_trip(composite_file, expert_files):
    c = composite.read(composite_file)
    assert c.names == ["slow_walk", "squat"] and c.loops == [True, False] and c.temperature == 0.3
    for pf, path in zip(c.experts, expert_files.values(), strict=True):
        own = policy_file.read(path)
        for key, value in own.arrays().items():
            np.testing.assert_array_equal(pf.arrays()[key], value)
        obs = np.random.default_rng(2).normal(size=(4, own.policy().observation_size))
        np.testing.assert_array_equal(pf.value()(obs), own.value()(obs))
    assert composite.is_composite(composite_file) and not composite.is_composite(expert_files["slow_walk"])


def test_compose_errors_are_one_line(tmp_path, character, clips, expert_files, capsys):
    walk, getup = (str(p) for p in expert_files.values())
    out = str(tmp_path / "c.npz")
    old = policy_file.write_npz(_expert(character, clips["squat"], 3, value=False), tmp_path / "old.npz")
    skilled = policy_file.write_npz(_expert(character, clips["squat"], 4, "phase,root_height,bodies,skill"),
                                    tmp_path / "skill.npz")
    scaled = policy_file.write_npz(_expert(character, clips["squat"], 5, overrides={"env.action_scale": 0.2}),
                                   tmp_path / "scaled.npz")
    other = policy_file.read(getup)
    other.manifest["character"] = dict(other.manifest["character"], sha256="f" * 64)
    other_path = policy_file.write_npz(other, tmp_path / "other.npz")
    cases = [([walk], "at least two experts, got 1"),
             ([walk, str(old)], "lacks its value network"),
             ([walk, str(skilled)], "observe differently"),
             ([walk, str(scaled)], "differ in control.action_scale (0.1 vs 0.2)"),
             ([walk, str(other_path)], "different characters"),
             ([getup, getup], "at least one expert on a looping")]
    for sources, message in cases:
        assert cli.main(["compose", *sources, "--out", out]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and message in err, err
    assert not Path(out).exists()  # nothing half-written
    assert "re-export" in composite_error(walk, str(old))


def composite_error(*paths) -> str:
    with pytest.raises(UserError) as err:
        composite.compose([policy_file.read(p) for p in paths])
    return str(err.value)


def test_compose_cli_prints_the_experts(expert_files, tmp_path, capsys):
    out = tmp_path / "c.npz"
    assert cli.main(["compose", *map(str, expert_files.values()), "--out", str(out), "--temperature", "0.5",
                     "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["temperature"] == 0.5 and [e["name"] for e in summary["experts"]] == ["slow_walk", "squat"]
    assert composite.read(out).temperature == 0.5


# ----------------------------------------------------------------------------------- recovery rule


def test_recovery_rule_on_made_up_trials():
    n = recovery.Steps(lead=3, push=1, down_within=3, recover=6, hold=2, total=12)
    stand = 1.0

    def run(heights, loco, errors):
        s = recovery.start((), np)
        for k, (h, lo, e) in enumerate(zip(heights, loco, errors)):
            s = recovery.update(s, k, h, lo, e, stand, n, np)
        return s

    up, down = 0.95, 0.2
    ok = [True] * 12
    small = [0.1] * 12
    s = run([up, up, up, up, down, down, 0.6, up, up, up, up, up], ok, small)
    assert (s.up_at_push, s.down_step, s.recovered_step) == (1, 4, 8)  # up at 7 and 8: held 2 steps
    s = run([up, up, up, up, down, down, 0.6, up, up, up, up, up], ok, [0.1] * 8 + [0.9] + [0.1] * 3)
    assert s.recovered_step == 10  # a step of bad tracking restarts the hold
    s = run([up, up, up, up, down, down, 0.6, up, up, up, up, up], [True] * 7 + [False] * 5, small)
    assert s.down_step == 4 and s.recovered_step == -1  # up, but not in a locomotion expert
    s = run([up, up, up, up, down] + [down] * 5 + [up, up], ok, small)
    assert s.recovered_step == -1  # up at 10 and 11: later than 6 steps after the fall at 4
    s = run([up, down, down, down, down, down, up, up, up, up, up, up], ok, small)
    assert s.up_at_push == 0 and s.down_step == -1  # it fell before the push: no knock-down
    s = run([up] * 12, ok, small)
    assert s.up_at_push == 1 and s.down_step == -1 and s.recovered_step == -1  # not knocked down
    out = recovery.summarize(np.array([1, 1, 0, 1]), np.array([4, -1, -1, 5]), np.array([8, -1, -1, -1]),
                             np.array([[3, 1], [4, 0], [1, 0], [2, 2]]), ["walk", "getup"], 2, 1 / 30)
    assert out["knockdowns"] == 2 and out["recovered"] == 1 and out["recovery_rate"] == 0.5
    assert out["knocked_trials"] == [0, 3] and out["not_knocked_down"] == 1 and out["fell_before_push"] == 1
    assert out["expert_share"] == {"walk": 5 / 8, "getup": 3 / 8}


def test_trials_are_the_same_in_any_batch():
    a = recovery.draw_trials(7, 0, 6, 1.4, "random", 10)
    b = recovery.draw_trials(7, 4, 2, 1.4, "random", 10)
    np.testing.assert_array_equal(a.start_time[4:], b.start_time)
    np.testing.assert_array_equal(a.u[4:], b.u)
    assert np.all(recovery.draw_trials(7, 0, 3, 1.4, "sideways", 4).turn == np.float32(np.pi / 2))


@pytest.fixture
def short_protocol(monkeypatch):
    """Knock-down trials of 0.3 s lead, 0.5 s to fall, 0.5 s to recover."""
    for name, value in (("LEAD_S", 0.3), ("DOWN_WITHIN_S", 0.5), ("RECOVER_S", 0.5), ("HOLD_S", 0.1)):
        monkeypatch.setattr(recovery, name, value)


@pytest.fixture(scope="module")
def still_composite(tmp_path_factory, character, clips):
    """Experts whose policies act zero (the PD follows each reference); random values."""
    experts = [_expert(character, clip, 10 + i, still=True) for i, clip in enumerate(clips.values())]
    for pf, name in zip(experts, clips, strict=True):
        pf.path = Path(f"{name}.npz")
    return composite.write(composite.compose(experts), tmp_path_factory.mktemp("still") / "still.npz")


def test_cpu_recovery_rate_counts_knockdowns(still_composite, short_protocol):
    c = composite.read(still_composite)
    out = composite.recovery_rate(c, knockdowns=2, force_n=3000.0, direction="forward", seed=0, max_trials=4)
    assert out["knockdowns"] == 2 and out["knocked_trials"] == [0, 1] and out["fell_before_push"] == 0
    assert 0.0 <= out["recovery_rate"] <= 1.0
    assert sum(out["expert_share"].values()) == pytest.approx(1.0)


def test_knocked_down_states_are_saved_for_getups_to_train_from(still_composite, short_protocol, tmp_path, capsys):
    out_file = tmp_path / "knocked.npz"
    args = ["play", str(still_composite), "--knockdowns", "2", "--force", "3000", "--push-direction", "forward",
            "--json", "--save-states", str(out_file)]
    assert cli.main(args) == 0
    result = json.loads(capsys.readouterr().out)
    c = composite.read(still_composite)
    knocked: list = []
    again = composite.recovery_rate(c, knockdowns=2, force_n=3000.0, direction="forward", seed=0,
                                    knocked_states=knocked)
    assert result["recovery_rate"] == again["recovery_rate"]  # collecting changes nothing
    scene = composite.Player(c).env.physics.scene
    qpos, qvel = start_bank.read(str(out_file), scene.nq, scene.nv)
    assert result["saved_states"] == {"file": str(out_file), "states": len(qpos)} and len(qpos) == len(knocked) > 0
    np.testing.assert_array_equal(qpos, np.array([q for q, _ in knocked], np.float32))
    up = recovery.UP_FRACTION * composite.Player(c).gate.stand_height
    assert (qpos[:, 2] < up + 0.2).all()  # bodies on their way down or lying, not walking tall
    assert [p.name for p in tmp_path.iterdir()] == ["knocked.npz"]  # no part file left behind


def test_save_states_errors_are_one_line(still_composite, composite_file, expert_files, tmp_path, capsys):
    for args, message in (
            ([str(still_composite), "--save-states", str(tmp_path / "k.npz")], "needs --knockdowns"),
            ([str(still_composite), "--knockdowns", "1", "--save-states", str(tmp_path / "k.txt")], "ending in .npz"),
            ([str(still_composite), "--knockdowns", "1", "--save-states", str(tmp_path / "no" / "k.npz")], "no folder"),
            ([str(expert_files["slow_walk"]), "--knockdowns", "1"], "--knockdowns is for composite files"),
            ([str(expert_files["slow_walk"]), "--seconds", "-1"], "--seconds is for composite files"),
            ([str(expert_files["slow_walk"]), "--expert", "walk"], "--expert is for composite files")):
        assert cli.main(["play", *args]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "k.npz").exists()


# ------------------------------------------------------------------------------------ CPU playback


def test_play_a_composite_without_jax_switches_experts(composite_file):
    code = ("import sys; from mjxmimic.cli import main; rc = main(sys.argv[1:]); "
            "print('JAX_IMPORTED=' + str(any(m == 'jax' or m.startswith('jax.') for m in sys.modules)), "
            "file=sys.stderr); sys.exit(rc)")
    result = subprocess.run([sys.executable, "-c", code, "play", str(composite_file), "--seconds", "1.5",
                             "--push-once", "3000@0.5", "--json"], cwd=REPO, env=dict(os.environ),
                            capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 0, result.stderr
    assert "JAX_IMPORTED=False" in result.stderr
    out = json.loads(result.stdout)
    assert out["seconds"] == pytest.approx(1.5) or out["lost_state"]
    names = {seg["expert"] for seg in out["timeline"]}
    assert names == {"slow_walk", "squat"}, out["timeline"]  # random values: the gate switches
    assert out["timeline"][0]["from_s"] == 0.0 and out["push"]["force_n"] == 3000.0
    assert sum(out["expert_share"].values()) == pytest.approx(1.0)


def test_clip_nr_with_its_own_expert_is_that_expert_s_nr(composite_file, expert_files):
    """Forcing a clip's own expert is playing that expert alone: its sim-to-sim NR on the same
    start times, to the bit; the gate's NR comes beside it."""
    from mjxmimic.portable.playback import evaluate

    c = composite.read(composite_file)
    out = composite.clip_nr(c, episodes=2, seed=4)
    for e, (name, path) in enumerate(expert_files.items()):
        pf = policy_file.read(path)
        env = CpuEnv(config_lib.playback_config(pf.config()), pf.character(), pf.clip())
        span = float(env.clip_durations[0]) - (0.0 if c.loops[e] else env.control_dt)
        starts = np.random.default_rng([4, e]).uniform(0.0, span, size=2)
        alone = evaluate(env, pf.policy(), starts)
        row = out["clips"][name]
        assert row["nr_own"] == pytest.approx(alone["nr"], abs=1e-9), (name, row, alone["nr"])
        assert 0.0 <= row["nr_gate"] <= 1.0 and 0.0 <= row["kept"] <= 1.0


def test_play_text_report(composite_file, capsys):
    assert cli.main(["play", str(composite_file), "--seconds", "0.3", "--temperature", "0"]) == 0
    text = capsys.readouterr().out
    assert "slow_walk" in text and "gate temperature 0" in text and "root height" in text
    assert cli.main(["play", str(composite_file), "--knockdowns", "0"]) == 2
    assert cli.main(["play", str(composite_file), "--push"]) == 2
    assert "--push is for single policies" in capsys.readouterr().err
    assert cli.main(["play", str(composite_file), "--expert", "run"]) == 2
    assert "unknown expert 'run'" in capsys.readouterr().err
    assert cli.main(["play", str(composite_file), "--seconds", "0.3", "--temperature", "-0.5"]) == 2
    assert "--temperature -0.5: must be >= 0" in capsys.readouterr().err  # would prefer the lowest values
    assert cli.main(["play", str(composite_file), "--push-once", "700"]) == 2
    assert "--push-once '700': expected FORCE@TIME" in capsys.readouterr().err  # the flag that was given
    assert cli.main(["play", str(composite_file), "--knockdowns", "1", "--force", "nan"]) == 2
    assert "--force nan: must be positive and finite" in capsys.readouterr().err


# ---------------------------------------------------------------------------- the gate on MJX


def test_the_gate_decides_alike_on_mjx(player, composite_file):
    """decide() under jit with MJX kinematics and the jax.numpy networks of runs.composite_eval
    gives the numpy player's values, probabilities, entry times and choice on the same states."""
    import jax
    import jax.numpy as jnp

    from mjxmimic.envs import step as step_lib
    from mjxmimic.envs.mjx_env import ImitationEnv
    from mjxmimic.runs.composite_eval import _networks

    c = composite.read(composite_file)
    env = player.env
    mjx = ImitationEnv(dataclasses.replace(env.config, physics=dataclasses.replace(env.config.physics, backend="jax")),
                       env.character, env.clips, max_worlds=1)
    values_of, _ = _networks(c)

    @jax.jit
    def decide(qpos, qvel, clip, t, u):
        motion = step_lib.Motion(clip=clip, time=t, steps=jnp.int32(0), root_offset=jnp.zeros(2), event_seed=0.0,
                                 goal=jnp.zeros(4))
        return gate_lib.decide(mjx.spec, gate, mjx.physics, qpos, qvel, motion, values_of, u)

    numpy_gate = player.gate._replace(temperature=0.3)
    gate = gate_lib.to_xp(numpy_gate, jnp)
    rng = np.random.default_rng(3)
    for clip, t in ((0, 0.3), (0, 1.1), (1, 0.5), (1, float(env.clip_durations[1]))):
        env.reset_at(t, clip=clip)
        env.data.qvel[:] += rng.normal(scale=0.3, size=env.data.qvel.shape)
        qpos, qvel = env.data.qpos.copy(), env.data.qvel.copy()
        u = np.float32(rng.uniform())
        want = gate_lib.decide(env.spec, numpy_gate, env.physics, qpos, qvel, env.motion, player.values_of, u)
        got = decide(jnp.asarray(qpos, jnp.float32), jnp.asarray(qvel, jnp.float32), jnp.int32(clip),
                     jnp.float32(env.motion.time), u)
        np.testing.assert_allclose(np.asarray(got.times), want.times, atol=1e-5)
        np.testing.assert_allclose(np.asarray(got.values), want.values, rtol=1e-3, atol=1e-3)
        np.testing.assert_allclose(np.asarray(got.probabilities), want.probabilities, atol=1e-3)
        assert int(got.choice) == int(want.choice)
        assert float(got.pose_error) == pytest.approx(float(want.pose_error), abs=1e-3)


def test_render_a_composite(composite_file, tmp_path, headless_video):
    from mjxmimic.portable.render import render_composite

    info = render_composite(composite.read(composite_file), tmp_path / "c.mp4", seconds=0.4, push=(3000.0, 0.1, 0.0),
                            width=160, height=128)
    assert info["frames"] == info["steps"] + 1 == 13 and info["timeline"][0]["from_s"] == 0.0


# ------------------------------------------------------------------ end to end with trained experts

EXPERT_SET = ["run.total_samples=4096", "run.eval_every=4096", "run.checkpoint_every=4096", "run.eval_episodes=4",
              "env.action_mode=residual", "env.action_scale=0.1"]


@pytest.mark.slow
def test_trained_experts_compose_and_recover_end_to_end(tmp_path, short_protocol, capsys, deepmimic_dir):
    """Two cpu-preset experts trained briefly (slow_walk, getup_facedown), exported with their
    value networks, composed, and the recovery evaluation run on the CPU and on MJX (the same
    trials: with a push strong enough, both knock the same trials down)."""
    from mjxmimic.runs import composite_eval

    experts = []
    getup = str(deepmimic_dir / "motions" / "humanoid3d_getup_facedown.txt")
    for name, clip in (("slow_walk", "slow_walk"), ("getup_facedown", getup)):
        run_dir = tmp_path / name
        args = ["train", "--preset", "cpu", "--clip", clip, "--out", str(run_dir), "--seed", "1"]
        for item in EXPERT_SET:
            args += ["--set", item]
        assert cli.main(args) == 0
        assert cli.main(["export", str(run_dir)]) == 0
        assert policy_file.read(run_dir / "policy.npz").has_value()
        experts.append(str(run_dir))
    out = tmp_path / "composite.npz"
    assert cli.main(["compose", *experts, "--out", str(out)]) == 0
    capsys.readouterr()
    c = composite.read(out)
    cpu = composite.recovery_rate(c, knockdowns=3, force_n=3000.0, direction="forward", seed=0, max_trials=6)
    mjx = composite_eval.recovery_rate(c, knockdowns=3, force_n=3000.0, direction="forward", seed=0, batch=6)
    for result in (cpu, mjx):
        assert result["knockdowns"] == 3, result
        assert 0.0 <= result["recovery_rate"] <= 1.0
        assert sum(result["expert_share"].values()) == pytest.approx(1.0)
    assert cpu["knocked_trials"] == mjx["knocked_trials"]
    assert cli.main(["eval", str(out), "--knockdowns", "1", "--force", "3000", "--batch", "2", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["knockdowns"] == 1
