"""Motion datasets (several clips in one controller): the file format and its errors, RSI by
weight, the skill selector, the max-of-clips reward and per-clip evaluation."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjxmimic import cli
from mjxmimic.core.config import make_config
from mjxmimic.core.errors import UserError
from mjxmimic.motion.dataset import is_dataset, load_dataset


def _write(tmp_path, data, name="set.json"):
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


def test_a_dataset_lists_clips_with_weights(tmp_path, character):
    path = _write(tmp_path, {"about": "notes", "clips": [{"clip": "slow_walk", "weight": 3}, "squat"]})
    assert is_dataset(path) and not is_dataset("slow_walk")
    data = load_dataset(path, character)
    assert [c.name for c in data.clips] == ["slow_walk", "squat"] and data.weights == [3.0, 1.0]
    yaml_path = _write(tmp_path, "clips:\n  - clip: wave\n    weight: 0.5\n  - squat\n", "set.yaml")
    assert [c.name for c in load_dataset(yaml_path, character).clips] == ["wave", "squat"]


@pytest.mark.parametrize("data, message", [
    ("{not json", "not valid JSON"),
    ({"clips": []}, "non-empty list"),
    ({"clips": "slow_walk"}, "non-empty list"),
    ({"clips": [3]}, r"clips\[0\]: expected a clip name"),
    ({"clips": [{"clip": "squat", "speed": 2}]}, r"clips\[0\]: unknown key 'speed'"),
    ({"clips": ["squat", {"clip": "wave", "weight": 0}]}, r"clips\[1\]: weight 0 must be a positive number"),
    ({"clips": [{"clip": "wave", "weight": True}]}, "must be a positive number"),
    ({"clips": ["squat", "no_such_clip"]}, r"clips\[1\]: unknown clip 'no_such_clip'"),
    ({"clips": ["squat", "squat"]}, "listed twice"),
])
def test_bad_datasets_are_one_line_errors(tmp_path, character, data, message):
    path = _write(tmp_path, data)
    with pytest.raises(UserError, match=message) as err:
        load_dataset(path, character)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_clips_info_summarises_a_dataset(tmp_path, capsys):
    path = _write(tmp_path, {"clips": [{"clip": "slow_walk", "weight": 3}, "squat"]})
    assert cli.main(["clips", "info", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["name"] for r in out["clips"]] == ["slow_walk", "squat"]
    assert [r["share"] for r in out["clips"]] == [0.75, 0.25]


@pytest.fixture(scope="module")
def two_clip_env(character, tmp_path_factory):
    from mjxmimic.envs.mjx_env import make_env

    path = _write(tmp_path_factory.mktemp("data"), {"clips": [{"clip": "slow_walk", "weight": 3}, "squat"]})
    config = make_config("cpu", {"clip.name": str(path), "env.action_mode": "residual", "physics.backend": "jax",
                                 "env.observations": "phase,root_height,bodies,skill", "reward.combine": "max",
                                 "run.eval_episodes": 2})
    return make_env(config)


def test_rsi_draws_clips_by_weight(two_clip_env):
    clips, _ = jax.vmap(two_clip_env.draw_start)(jax.random.split(jax.random.PRNGKey(0), 4000))
    share = float(np.mean(np.asarray(clips) == 0))
    assert 0.72 < share < 0.78  # weights 3 : 1


@pytest.mark.slow
def test_skill_selector_and_max_of_clips_reward(two_clip_env):
    env = two_clip_env
    reset = jax.jit(env.reset_at)
    step = jax.jit(env.transition)
    for clip in (0, 1):
        state = reset(jax.random.PRNGKey(clip), 0.2, clip)
        np.testing.assert_array_equal(np.asarray(state.obs[-2:]), np.eye(2)[clip])  # the one-hot
        nxt = step(state, jnp.zeros(env.action_size))
        own, best = float(nxt.metrics["reward/own_clip"]), float(nxt.metrics["reward/imitation"])
        assert best >= own - 0.02  # the max includes the env's own clip (turned to the character)
        assert best > 0.5


@pytest.mark.slow
@pytest.mark.parametrize("entry", ["phase", "nearest"])
def test_training_switches_the_skill_on_mjx(character, tmp_path, entry):
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.envs.mjx_env import make_env
    from mjxmimic.motion.clip import load_clip_source

    path = _write(tmp_path, {"clips": ["slow_walk", "squat"]})
    overrides = {"env.action_mode": "residual", "env.observations": "phase,root_height,bodies,skill",
                 "env.skill_switch_s": 1.0 / 30, "env.skill_switch_entry": entry,  # a switch every step
                 "env.skill_switch_settle_s": 0.1}
    env = make_env(make_config("cpu", {"clip.name": str(path), "physics.backend": "jax", **overrides}))
    state = jax.jit(env.reset_at)(jax.random.PRNGKey(0), 0.2, 0)
    nxt = jax.jit(env.transition)(state, jnp.zeros(env.action_size))
    np.testing.assert_array_equal(np.asarray(nxt.obs[-2:]), [0.0, 1.0])  # now the squat's one-hot
    # the same switch on MuJoCo C enters the squat at the same time
    cpu = CpuEnv(make_config("cpu", overrides), character,
                 [load_clip_source("slow_walk", character), load_clip_source("squat", character)])
    cpu.reset_at(0.2, clip=0)
    cpu.step(np.zeros(character.action_size))
    assert cpu.motion.clip == 1 and float(nxt.info["time"]) == pytest.approx(cpu.time, abs=1e-5)
    assert int(nxt.info["settle"]) == cpu.motion.settle == 3
    np.testing.assert_allclose(np.asarray(nxt.info["root_offset"]), cpu.motion.root_offset, atol=1e-4)


@pytest.mark.slow
def test_evaluation_reports_each_clip(two_clip_env):
    from mjxmimic.runs.evaluate import evaluate

    env = two_clip_env
    out = evaluate(env, lambda obs, key: jnp.zeros(obs.shape[:-1] + (env.action_size,)), env.config, seed=0)
    per = {name: out[f"clip/{name}/nr"] for name in ("slow_walk", "squat")}
    assert out["nr"] == pytest.approx(0.75 * per["slow_walk"] + 0.25 * per["squat"])
    assert out["episodes"] == 4 and {f"clip/squat/{k}" for k in ("nr_paper", "fall_rate")} <= set(out)


def test_max_of_one_clip_is_its_own_reward_on_mujoco_c(character):
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source

    clip = load_clip_source("slow_walk", character)
    rewards = {}
    for combine in ("own", "max"):
        env = CpuEnv(make_config("cpu", {"env.action_mode": "residual", "reward.combine": combine}), character, clip)
        env.reset_at(0.4)
        rewards[combine] = env.step(np.zeros(character.action_size)).metrics["reward/imitation"]
    assert rewards["max"] == pytest.approx(rewards["own"], abs=0.01)


@pytest.mark.slow
def test_train_on_a_dataset_end_to_end(tmp_path, capsys):
    path = _write(tmp_path, {"clips": [{"clip": "slow_walk", "weight": 2}, "squat"]})
    run = tmp_path / "run"
    code = cli.main(["train", "--preset", "cpu", "--clip", str(path), "--out", str(run),
                     "--set", "env.observations=phase,root_height,bodies,skill", "--set", "reward.combine=max",
                     "--set", "env.skill_switch_s=0.2",  # switches traced on MJX; evaluation without them
                     "--set", "env.skill_switch_settle_s=0.1",
                     "--set", "run.total_samples=4096", "--set", "run.eval_every=4096", "--set", "run.eval_at_start=false"])
    assert code == 0
    final = json.loads((run / "eval.json").read_text())
    assert {"clip/slow_walk/nr", "clip/squat/nr", "clip/squat/nr_paper_discounted"} <= set(final)
    assert 0 <= final["nr"] <= 1
    # the policy exports with both clips and plays each of them, and a skill sequence, on MuJoCo C
    policy = tmp_path / "policy.npz"
    assert cli.main(["export", str(run), "--out", str(policy)]) == 0
    capsys.readouterr()
    assert cli.main(["play", str(policy), "--episodes", "2", "--json"]) == 0
    played = json.loads(capsys.readouterr().out)
    rows = played["clips"]
    assert "(CPU, mj_step)" in played["simulator"]
    assert set(rows) == {"slow_walk", "squat"}
    for name, row in rows.items():  # the MJX evaluation's NR of each clip came along
        assert row["mjx_nr"] == pytest.approx(final[f"clip/{name}/nr"]) and 0 <= row["nr"] <= 1
    assert cli.main(["play", str(policy), "--skill-sequence", "squat:0.2,slow_walk:0.2", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["segments"][0]["skill"] == "squat"

