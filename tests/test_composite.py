"""Composite policies (mjxmimic.portable.composite): the value network in the policy file, `compose`
and its checks, the gate (softmax over values, no immediate repeat), the recovery test through
`mjxmimic play`. Random weights; the gate runs on MuJoCo C without JAX."""

import dataclasses
import itertools
import json

import numpy as np
import pytest

from mjxmimic import cli
from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.motion.clip import load_clip_source
from mjxmimic.portable import composite, policy_file
from mjxmimic.portable.policy_numpy import NumpyValue


def _mlp(rng, sizes):
    return {f"hidden_{i}": {"kernel": rng.normal(scale=0.1 / np.sqrt(a), size=(a, b)).astype(np.float32),
                            "bias": np.zeros(b, np.float32)} for i, (a, b) in enumerate(itertools.pairwise(sizes))}


def _expert(character, clip, seed=0, value_bias=0.0, overrides=None):
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.action_scale": 0.1,
                                            **(overrides or {})})
    obs = CpuEnv(config, character, clip).observation_size
    rng = np.random.default_rng(seed)
    value = _mlp(rng, [obs, 16, 1])
    value["hidden_1"]["bias"][:] = value_bias
    params = {"normalizer": {"mean": np.zeros(obs, np.float32), "std": np.ones(obs, np.float32)},
              "policy": _mlp(rng, [obs, 16, 2 * character.action_size]), "value": value}
    return policy_file.make_policy_file(config, character, [clip], params)


@pytest.fixture(scope="module")
def walk_and_squat(character):
    walk = load_clip_source("slow_walk", character)
    squat = dataclasses.replace(load_clip_source("squat", character), loop=False)  # a one-shot skill
    return walk, squat


def test_the_value_network_travels_and_matches_jax(tmp_path, character, walk_and_squat):
    import jax

    from mjxmimic.learn.ppo import make_networks

    pf = policy_file.read(policy_file.write_npz(_expert(character, walk_and_squat[0]), tmp_path / "e.npz"))
    obs = np.random.default_rng(1).normal(size=(5, pf.params["normalizer"]["mean"].shape[0]))
    config = config_lib.make_config("cpu", {"ppo.value_hidden": "16"})
    networks = make_networks(obs.shape[1], character.action_size, config)
    from brax.training.acme import running_statistics

    normalizer = running_statistics.NestedMeanStd(mean=pf.params["normalizer"]["mean"],
                                                  std=pf.params["normalizer"]["std"])
    want = jax.jit(networks.value_network.apply)(normalizer, {"params": pf.params["value"]}, obs)
    np.testing.assert_allclose(NumpyValue(pf.params)(obs), np.asarray(want), rtol=1e-5, atol=1e-6)


def test_gate_probabilities():
    p = composite.gate_probabilities(np.array([1.0, 1.3, 5.0]), np.array([True, True, False]), 0.3)
    assert p[2] == 0.0 and p.sum() == pytest.approx(1.0)
    assert p[1] / p[0] == pytest.approx(np.exp(0.3 / 0.3))


def test_compose_checks_its_experts(character, walk_and_squat):
    walk, squat = walk_and_squat
    a, b = _expert(character, walk), _expert(character, squat, seed=1)
    with pytest.raises(UserError, match="at least two"):
        composite.compose([a])
    no_value = dataclasses.replace(b, params={k: v for k, v in b.params.items() if k != "value"})
    with pytest.raises(UserError, match="no value network"):
        composite.compose([a, no_value])
    other = _expert(character, squat, overrides={"env.physics_hz": 240})
    with pytest.raises(UserError, match="'env.physics_hz'"):
        composite.compose([a, other])
    with pytest.raises(UserError, match="temperature"):
        composite.compose([a, b], temperature=0.0)


def test_the_gate_follows_the_values_and_never_repeats_a_finished_skill(tmp_path, character, walk_and_squat):
    walk, squat = walk_and_squat
    experts = [_expert(character, walk), _expert(character, squat, seed=1, value_bias=10.0)]
    path = composite.write(composite.compose(experts), tmp_path / "c.npz")
    assert composite.is_composite(path) and not composite.is_composite(tmp_path / "missing.npz")
    comp = composite.read(path)
    assert comp.names == ["slow_walk", "squat"] and comp.temperature == composite.TEMPERATURE
    gate = composite.Gate(comp, seed=0)
    gate.reset(0, 0.3)
    s, expert = gate.step()
    assert expert == 1 and gate.env.motion.clip == 1  # the far higher value wins
    assert float(gate.env.time) == pytest.approx(1 / 30, abs=1e-5)  # a one-shot skill starts at its beginning
    chosen = [expert]
    for _ in range(round(float(gate.env.clip_durations[1]) * 30) + 3):
        s, expert = gate.step()
        chosen.append(expert)
    first_walk = chosen.index(0)  # once the squat ended, the walk had to play
    assert all(e == 1 for e in chosen[:first_walk]) and chosen[first_walk + 1] == 1


def test_play_runs_the_recovery_test_of_a_composite(tmp_path, capsys, character, walk_and_squat):
    walk, squat = walk_and_squat
    path = composite.write(composite.compose([_expert(character, walk), _expert(character, squat, seed=1)]),
                           tmp_path / "c.npz")
    assert cli.main(["play", str(path), "--knockdowns", "2", "--push-force", "3000", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["knockdowns"] == len(out["trials"]) <= 2 and out["pushes"] >= 1
    assert set(out["expert_time_share"]) == {"slow_walk", "squat"}
    assert sum(out["expert_time_share"].values()) == pytest.approx(1.0, abs=1e-3)
