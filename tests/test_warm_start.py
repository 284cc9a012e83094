"""A new run started from a trained policy (`mjxmimic train --init-from`, run.init_from): the
networks and normaliser carried exactly, one-line errors where the source does not fit, and (slow)
a run that starts with the NR its source ended with."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import jax
import numpy as np
import pytest
from brax.training import types as brax_types

from mjxmimic.cli import main as cli_main
from mjxmimic.commands.train import add_arguments, resolve_run
from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.envs.mjx_env import make_env
from mjxmimic.learn.ppo import TrainState, make_trainer
from mjxmimic.portable import policy_file as policy_format
from mjxmimic.runs import checkpoint, export, metrics_log
from mjxmimic.runs.train_loop import train
from mjxmimic.runs.warm_start import apply_start, read_start

TINY = {"run.total_samples": 1024, "ppo.num_envs": 8, "ppo.unroll_length": 4, "ppo.num_minibatches": 2,
        "run.eval_episodes": 2, "env.episode_seconds": 1, "env.physics_hz": 30, "run.eval_every": 100000}


@pytest.fixture(scope="module")
def config():
    return config_lib.make_config("cpu", TINY)


@pytest.fixture(scope="module")
def env(config):
    return make_env(config)


def _fresh_state(env, config, seed: int) -> TrainState:
    params, opt_state, normalizer = make_trainer(env, config).init_learner(jax.random.PRNGKey(seed))
    return TrainState(params=params, optimizer_state=opt_state, normalizer=normalizer, env_state=None,
                      key=jax.random.PRNGKey(seed), env_steps=brax_types.UInt64(hi=0, lo=0))


@pytest.fixture(scope="module")
def source(tmp_path_factory, env, config) -> Path:
    """An exported policy of a run that 'trained' 5,000,000,123 samples (more than 32 bits hold),
    its normaliser randomised so that every part of it matters."""
    run_dir = tmp_path_factory.mktemp("source") / "run"
    run_dir.mkdir()
    config_lib.save(config, run_dir / "config.json")
    ts = _fresh_state(env, config, seed=7)
    rng = np.random.default_rng(7)
    n = env.observation_size
    ts = ts.replace(normalizer=ts.normalizer.replace(mean=rng.normal(size=n).astype(np.float32),
                                                     std=rng.uniform(0.5, 2.0, size=n).astype(np.float32)),
                    env_steps=brax_types.UInt64(hi=1, lo=5_000_000_123 - 2**32))
    checkpoint.save(run_dir, ts, iterations=1, elapsed_seconds=1.0)
    return export.export_run(run_dir)[0]


def test_the_networks_and_normaliser_are_carried_exactly(source, env):
    config = config_lib.make_config("cpu", {**TINY, "run.init_from": str(source)})
    pf = read_start(config, env.character, [c.name for c in env.clips])
    # a run folder names its exported policy
    of_folder = read_start(config_lib.apply_overrides(config, {"run.init_from": str(source.parent)}),
                           env.character, [c.name for c in env.clips])
    np.testing.assert_array_equal(of_folder.params["policy"]["hidden_0"]["kernel"],
                                  pf.params["policy"]["hidden_0"]["kernel"])
    ts = apply_start(_fresh_state(env, config, seed=0), pf, config)
    for net in ("policy", "value"):
        got = jax.tree_util.tree_map(np.asarray, getattr(ts.params, net)["params"])
        want = pf.params[net]
        assert got.keys() == want.keys()
        for name in want:
            for k in ("kernel", "bias"):
                np.testing.assert_array_equal(got[name][k], want[name][k])
    np.testing.assert_array_equal(np.asarray(ts.normalizer.mean), pf.params["normalizer"]["mean"])
    np.testing.assert_array_equal(np.asarray(ts.normalizer.std), pf.params["normalizer"]["std"])
    # the source's samples as the normaliser's count, so that it moves as slowly as it would have there
    samples = pf.manifest["training"]["samples"]
    assert int(ts.normalizer.count.hi) * 2**32 + int(ts.normalizer.count.lo) == samples
    np.testing.assert_allclose(np.asarray(ts.normalizer.summed_variance) / samples,
                               pf.params["normalizer"]["std"] ** 2, rtol=1e-5)


def _one_line_error(capsys) -> str:
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mjxmimic train: error:"), lines
    return lines[0]


@pytest.mark.parametrize("flags, message", [
    (["--set", "ppo.policy_hidden=32,32"],
     "the policy network's layer hidden_0 is bias (64,), kernel (227, 64) there, "
     "bias (32,), kernel (227, 32) here (set ppo.policy_hidden as the source was trained)"),
    (["--set", "ppo.value_hidden=64"], "the value network's layer hidden_1 is"),
    (["--set", "env.observations=phase,bodies"],
     "its observation does not fit this run's: part 2 is 'root_height' (1) there, 'body_position' (45) here"),
    (["--set", "env.observation_heading=twist"], "it observes in the 'forward' heading frame, this run in the 'twist' one"),
])
def test_a_source_that_does_not_fit_is_one_line_and_writes_nothing(source, tmp_path, capsys, flags, message):
    out = tmp_path / "run"
    args = ["train", "--preset", "cpu", "--out", str(out), "--init-from", str(source)]
    assert cli_main(args + flags + [f"--set={k}={v}" for k, v in TINY.items()]) == 2
    assert message in _one_line_error(capsys)
    assert not out.exists()


def test_init_from_errors_are_one_line(source, tmp_path, capsys):
    out = tmp_path / "run"
    assert cli_main(["train", "--preset", "cpu", "--out", str(out), "--init-from", str(tmp_path / "nope.npz")]) == 2
    assert f"run.init_from {tmp_path / 'nope.npz'}: no such policy file or run folder" in _one_line_error(capsys)
    arrays = policy_format.load_arrays(source)
    np.savez(tmp_path / "no_value.npz", **{k: v for k, v in arrays.items() if not k.startswith("value/")})
    assert cli_main(["train", "--preset", "cpu", "--out", str(out), "--init-from", str(tmp_path / "no_value.npz")]) == 2
    assert "lacks the value network" in _one_line_error(capsys)
    assert not out.exists()
    assert cli_main(["train", "--resume", str(tmp_path), "--init-from", str(source)]) == 2
    assert "--init-from cannot be combined with --resume" in _one_line_error(capsys)


@pytest.mark.slow
def test_a_run_started_from_another_starts_with_its_nr(tmp_path, env, capsys):
    """Run A trains a little and ends with an evaluation; run B (the same seed, so the same
    evaluation starts), started from A's export, is evaluated before its first iteration: A's last
    NR to the last bit (the untrained policy scores 0.24 here), and that evaluation is not kept as
    B's best."""
    first = config_lib.make_config("cpu", {**TINY, "run.eval_at_start": False})
    train(first, tmp_path / "A", env=env, progress=False)
    end_of_a = json.loads((tmp_path / "A" / "eval.json").read_text())["nr"]
    policy, _ = export.export_run(tmp_path / "A", tmp_path / "A.npz", which="latest")
    assert [r["eval/nr"] for r in metrics_log.read(tmp_path / "A") if "eval/nr" in r] == [end_of_a]

    args = ["train", "--preset", "cpu", "--out", str(tmp_path / "B"), "--init-from", str(policy),
            "--set", "run.eval_at_start=true"]
    assert cli_main(args + [f"--set={k}={v}" for k, v in TINY.items()]) == 0
    assert f"starting from {policy} (trained 1,024 samples" in capsys.readouterr().err
    evals = [(r["step"], r["eval/nr"]) for r in metrics_log.read(tmp_path / "B") if "eval/nr" in r]
    assert evals[0] == (0, end_of_a)
    assert config_lib.load(tmp_path / "B" / "config.json").run.init_from == str(policy)
    best = json.loads((tmp_path / "B" / "best.json").read_text())
    assert best["checkpoint"] == 1024


def test_the_flag_sets_the_config_key(source):
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    config, _, resuming = resolve_run(parser.parse_args(["--preset", "cpu", "--init-from", str(source),
                                                         "--out", "/tmp/never-made"]))
    assert config.run.init_from == str(source) and not resuming
    with pytest.raises(UserError, match="run.init_from"):
        read_start(config_lib.apply_overrides(config, {"run.init_from": "/nowhere"}), None, [])
