"""The NR protocol (mjxmimic.runs.evaluate) on the stand-in env, where the right answers are known."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjxmimic import cli
from mjxmimic.core.config import make_config
from mjxmimic.runs.evaluate import Evaluator, evaluate
from mjxmimic.task.nr import fall_windows
from standin_env import StandInEnv

CONFIG = make_config("cpu", {"run.eval_episodes": 8})


def perfect_policy(env):
    n = env.n

    def policy(obs, key):  # x' = x + (a - x)/2 = ref(t + dt)  =>  a = 2 ref(t + dt) - x
        x, ref_next = obs[..., :n], obs[..., 2 * n:3 * n]
        return jnp.clip(2 * ref_next - x, -1.0, 1.0)

    return policy


def zero_policy(obs, key):
    return jnp.zeros(obs.shape[:-1] + (4,))


def test_perfect_tracking_scores_one_on_a_looping_clip():
    env = StandInEnv()
    out = evaluate(env, perfect_policy(env), CONFIG, seed=0, samples=123, train_seconds=4.5)
    assert out["nr"] == pytest.approx(1.0, abs=1e-4)
    assert out["nr_paper_discounted"] == pytest.approx(1.0, abs=1e-4)
    assert out["fall_rate"] == 0.0
    assert out["survival_s"] == pytest.approx(20.0, abs=1e-6)  # 600 steps, beyond the env's own time limit
    assert out["mean_horizon_steps"] == 600
    assert out["pose_error_rad"] < 1e-4
    assert out["episodes"] == 8
    assert out["samples"] == 123 and out["train_seconds"] == 4.5
    assert out["simulator"] == env.physics.simulator  # the result names what made it


def test_fall_ends_the_episode_and_remaining_steps_count_zero():
    env = StandInEnv()
    out = evaluate(env, zero_policy, CONFIG, seed=0)
    assert out["fall_rate"] == 1.0
    assert out["survival_s"] < 20.0
    # every step after the fall counts 0: NR <= fraction of the horizon survived
    assert 0.0 < out["nr"] <= out["survival_s"] / 20.0 + 1e-6


def test_the_evaluation_stops_once_every_episode_has_ended():
    env = StandInEnv()
    tracked = evaluate(env, perfect_policy(env), CONFIG, seed=0)
    assert tracked["steps_run"] == 600  # nobody fell: the whole horizon
    fallen = evaluate(env, zero_policy, CONFIG, seed=0)
    assert fallen["fall_rate"] == 1.0
    # the batch stopped at the last fall, not at the horizon (its episodes' mean survival is below that)
    assert fallen["survival_s"] * 30 <= fallen["steps_run"] < 600
    short = evaluate(StandInEnv(looping=False, clip_duration=2.0), perfect_policy(env), CONFIG, seed=1)
    assert short["steps_run"] <= 60


def test_non_looping_clip_runs_to_the_clip_end():
    env = StandInEnv(looping=False, clip_duration=2.0)
    out = evaluate(env, perfect_policy(env), CONFIG, seed=1)
    assert out["nr"] == pytest.approx(1.0, abs=1e-4)  # the clip's end is not a fall
    assert out["fall_rate"] == 0.0
    assert 0 < out["mean_horizon_steps"] <= 60
    assert out["survival_s"] == pytest.approx(out["mean_horizon_steps"] / 30.0, rel=1e-5)


def test_nr_is_mean_of_per_episode_return_over_horizon():
    """Reproduce NR by hand with a plain Python loop over one episode at a time."""
    env = StandInEnv(looping=False, clip_duration=1.0)

    def half(obs, key):  # a policy that tracks badly but mostly survives for a while
        return 0.5 * perfect_policy(env)(obs, key)

    out = evaluate(env, half, CONFIG, seed=3)
    key = jax.random.PRNGKey(3)
    k_time, k_reset, _ = jax.random.split(key, 3)
    n = CONFIG.run.eval_episodes
    t0 = jax.random.uniform(k_time, (n,), minval=0.0, maxval=env.clip_duration)
    resets = jax.random.split(k_reset, n)
    nrs, discounted = [], []
    for i in range(n):
        state = env.reset_at(resets[i], t0[i])
        horizon = max(int(env.eval_horizon(t0[i])), 1)
        total, total_discounted = 0.0, 0.0
        for k in range(horizon):
            state = env.transition(state, half(state.obs, None))
            total += float(state.reward)
            total_discounted += 0.95 ** k * float(state.reward)  # the stand-in grades both forms alike
            if float(state.metrics["fell"]) > 0:
                break
        nrs.append(total / horizon)
        discounted.append(total_discounted / sum(0.95 ** k for k in range(horizon)))
    assert out["nr"] == pytest.approx(float(np.mean(nrs)), abs=1e-5)
    assert out["nr_paper_discounted"] == pytest.approx(float(np.mean(discounted)), abs=1e-5)


def test_a_grid_of_starts_covers_the_clip_and_names_where_falls_start():
    env = StandInEnv(clip_duration=1.0)
    tracked = evaluate(env, perfect_policy(env), CONFIG, grid=0.25)
    assert tracked["episodes"] == 4 and tracked["grid_s"] == 0.25  # starts 0, 0.25, 0.5, 0.75
    assert tracked["nr"] == pytest.approx(1.0, abs=1e-4) and tracked["fall_windows"] == []
    fallen = evaluate(env, zero_policy, CONFIG, grid=0.25)
    assert fallen["fall_windows"] == [[0.0, 0.75, 4]]  # every start falls: one run of them
    drawn = evaluate(env, zero_policy, CONFIG, seed=0)
    assert sum(n for _, _, n in drawn["fall_windows"]) == round(drawn["fall_rate"] * drawn["episodes"])


def test_fall_windows_are_runs_of_falling_starts_in_clip_order():
    starts = [0.3, 0.1, 0.0, 0.2, 0.5, 0.4, 0.6]
    fell = [True, True, False, True, True, False, False]
    assert fall_windows(starts, fell) == [[0.1, 0.3, 3], [0.5, 0.5, 1]]
    assert fall_windows(starts, [False] * 7) == []


def test_evaluator_matches_evaluate_and_compiles_once():
    from mjxmimic.learn.ppo import export_params, make_trainer

    env = StandInEnv()
    trainer = make_trainer(env, CONFIG)
    ts = trainer.init(0)
    params = export_params(ts)
    evaluator = Evaluator(env, CONFIG, trainer.make_policy)
    a = evaluator(params, seed=5)
    b = evaluate(env, trainer.make_policy(params, True), CONFIG, seed=5)
    for key in ("nr", "fall_rate", "survival_s", "pose_error_rad"):
        assert a[key] == pytest.approx(b[key], rel=1e-5, abs=1e-7)
    params2 = jax.tree_util.tree_map(lambda x: x * 1.01, params)
    evaluator(params2, seed=6)
    assert evaluator._run._cache_size() == 1


def test_stochastic_evaluation_grades_the_training_policy_on_the_same_starts():
    from mjxmimic.learn.ppo import export_params, make_trainer

    env = StandInEnv()
    config = make_config("cpu", {"run.eval_episodes": 8, "run.eval_stochastic": True,
                                 "ppo.init_action_std": 1.0})
    trainer = make_trainer(env, config)
    params = export_params(trainer.init(0))
    result = Evaluator(env, config, trainer.make_policy)(params, seed=5)
    deterministic = evaluate(env, trainer.make_policy(params, True), config, seed=5)
    stochastic = evaluate(env, trainer.make_policy(params, False), config, seed=5)
    assert result["nr"] == pytest.approx(deterministic["nr"], rel=1e-5)
    for key in Evaluator.STOCHASTIC_FIELDS:
        assert result[f"stochastic_{key}"] == pytest.approx(stochastic[key], rel=1e-5, abs=1e-7)
    # std 1 moves the stand-in visibly: the two policies are graded apart
    assert result["stochastic_nr"] != pytest.approx(result["nr"], rel=0.05)


def test_eval_cli_grid_refusals(tmp_path, capsys):
    assert cli.main(["eval", str(tmp_path), "--grid", "0.1", "--episodes", "4"]) == 2
    assert "--grid sets the episodes itself" in capsys.readouterr().err
    assert cli.main(["eval", str(tmp_path), "--grid", "0.1", "--push"]) == 2
    assert "--grid is for the NR" in capsys.readouterr().err


def test_eval_cli_missing_run_folder(tmp_path, capsys):
    code = cli.main(["eval", str(tmp_path / "nope")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and "run folder not found" in err


def test_eval_cli_folder_without_checkpoint(tmp_path, capsys):
    from mjxmimic.core import config as config_lib

    config_lib.save(CONFIG, tmp_path / "config.json")
    code = cli.main(["eval", str(tmp_path)])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and "no checkpoint" in err


def test_missing_warp_notice_never_reaches_the_terminal(tmp_path):
    """mujoco.mjx prints a notice when warp-lang is absent (blocked here to be sure it is)."""
    import subprocess
    import sys

    code = ("import sys; sys.modules['warp'] = None; from mjxmimic.cli import main; "
            "sys.exit(main(sys.argv[1:]))")
    result = subprocess.run([sys.executable, "-c", code, "eval", str(tmp_path / "missing")],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert "Failed to import" not in result.stdout + result.stderr
    assert result.stderr.strip().splitlines() == [f"mjxmimic eval: error: {tmp_path / 'missing'}: run folder not found"]
