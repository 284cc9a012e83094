"""Policies of several clips on the CPU: the policy file carries every clip, `play` grades each, and
`--skill-sequence` switches the skill one-hot (mjxmimic.portable.skills). Random weights, no JAX."""

import dataclasses
import itertools
import json

import numpy as np
import pytest

from mjxmimic import cli
from mjxmimic.core import config as config_lib
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.motion.clip import load_clip_source
from mjxmimic.portable import policy_file
from mjxmimic.portable.skills import parse_sequence

SKILLED = "phase,root_height,bodies,skill"


def _random_policy(character, clips, observations: str, weights=None):
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.action_scale": 0.1,
                                            "env.observations": observations})
    obs = CpuEnv(config, character, clips).observation_size
    rng = np.random.default_rng(0)
    sizes = [obs, 32, 32, 2 * character.action_size]
    policy = {f"hidden_{i}": {"kernel": rng.normal(scale=0.1 / np.sqrt(a), size=(a, b)).astype(np.float32),
                              "bias": np.zeros(b, np.float32)} for i, (a, b) in enumerate(itertools.pairwise(sizes))}
    params = {"normalizer": {"mean": np.zeros(obs, np.float32), "std": np.ones(obs, np.float32)}, "policy": policy}
    return policy_file.make_policy_file(config, character, clips, params, weights=weights)


@pytest.fixture(scope="module")
def two_clips(character):
    return [load_clip_source("slow_walk", character), load_clip_source("squat", character)]


@pytest.fixture(scope="module")
def skilled_file(tmp_path_factory, character, two_clips):
    pf = _random_policy(character, two_clips, SKILLED, weights=[2.0, 1.0])
    return policy_file.write_npz(pf, tmp_path_factory.mktemp("skills") / "skills.npz")


def test_the_file_carries_every_clip(skilled_file, two_clips):
    pf = policy_file.read(skilled_file)
    clips = pf.clips()
    assert [c.name for c in clips] == ["slow_walk", "squat"] and pf.weights() == [2.0, 1.0]
    for ours, theirs in zip(clips, two_clips, strict=True):
        np.testing.assert_array_equal(ours.qpos, theirs.qpos)
        assert ours.loop == theirs.loop
    assert pf.manifest["dataset"]["clips"][1]["frames"] == two_clips[1].num_frames
    assert "clip/1/qpos" in pf.manifest["arrays"] and pf.clip().name == "slow_walk"


def test_switch_keeps_the_phase_and_flips_the_skill(character, two_clips):
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.observations": SKILLED})
    env = CpuEnv(config, character, two_clips)
    obs = env.reset_at(0.25 * float(env.clip_durations[0]))
    assert list(obs[-2:]) == [1.0, 0.0]
    obs = env.switch(1)
    assert list(obs[-2:]) == [0.0, 1.0] and env.motion.clip == 1
    assert env.time == pytest.approx(0.25 * float(env.clip_durations[1]), abs=1e-5)
    ref, _ = env.reference(env.time)  # the reward now grades the squat
    assert ref.shape == (character.nq,)


def test_switch_moves_the_reference_under_the_character(character, two_clips):
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.observations": SKILLED})
    env = CpuEnv(config, character, two_clips)
    env.reset_at(0.1)
    for _ in range(15):  # the body drifts from the walk's reference
        env.step(np.zeros(character.action_size))
    env.switch(1)
    ref, _ = env.reference(env.time)
    np.testing.assert_allclose(ref[0:2], env.data.qpos[0:2], atol=1e-6)


def _switching_env(character, clips, seconds):
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.observations": SKILLED,
                                            "env.skill_switch_s": seconds})
    return CpuEnv(config, character, clips)


def test_training_switches_the_skill(character, two_clips):
    env = _switching_env(character, two_clips, 1.0 / 30)  # one switch per control step
    env.reset_at(0.2, clip=0)
    s = env.step(np.zeros(character.action_size))
    assert not s.done and env.motion.clip == 1 and list(s.obs[-2:]) == [0.0, 1.0]
    assert env.time == pytest.approx((0.2 + 1 / 30) / float(env.clip_durations[0]) * float(env.clip_durations[1]),
                                     abs=1e-5)
    ref, _ = env.reference(env.time)
    np.testing.assert_allclose(ref[0:2], env.data.qpos[0:2], atol=1e-6)


def test_skill_switches_come_at_the_configured_rate(character, two_clips):
    from mjxmimic.envs.skill_switch import maybe_switch_skill

    env = _switching_env(character, two_clips, 0.5)  # p = (1/30) / 0.5 per step
    env.reset_at(0.2)
    sim = env.physics.kinematics(env.data.qpos, env.data.qvel)
    switched = [int(maybe_switch_skill(env.spec, env.motion._replace(event_seed=seed, steps=k), env.motion.time,
                                       env.data.qpos, np.zeros((), bool), np, sim).clip)
                for seed in np.linspace(0.0, 1.0, 60, endpoint=False) for k in range(50)]
    assert np.mean(switched) == pytest.approx(1 / 15, abs=0.015)


@pytest.fixture(scope="module")
def walk_and_one_off(two_clips):
    """The walk and a squat that does not loop (a one-off skill, as a getup or a kick)."""
    return [two_clips[0], dataclasses.replace(two_clips[1], name="squat_once", loop=False)]


def test_a_one_off_skill_starts_where_the_cycle_ends_and_hands_back_at_its_end(character, walk_and_one_off):
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.observations": SKILLED})
    env = CpuEnv(config, character, walk_and_one_off)
    walk, once = (float(d) for d in env.clip_durations)
    env.reset_at(0.5 * walk)
    obs = env.switch(1)
    assert env.motion.clip == 0 and list(obs[-2:]) == [1.0, 0.0]  # asked for, not yet
    times = [env.time]
    while env.motion.clip == 0 and len(times) < 30:
        s = env.step(np.zeros(character.action_size))
        times.append(env.time)
    assert times[-2] < walk <= times[-2] + 1.01 * env.control_dt  # the step that crossed the cycle's end
    assert env.time == 0.0 and list(s.obs[-2:]) == [0.0, 1.0]
    ref, _ = env.reference(env.time)
    np.testing.assert_allclose(ref[0:2], env.data.qpos[0:2], atol=1e-6)
    env.motion = env.motion._replace(time=np.float32(once - 0.5 * env.control_dt))  # near the squat's end
    s = env.step(np.zeros(character.action_size))
    assert env.motion.clip == 0 and env.time == 0.0  # the walk again, from its start
    assert not s.failed and not s.done and not s.clip_end and list(s.obs[-2:]) == [1.0, 0.0]


def test_training_switches_out_of_a_one_off_skill_at_its_end(character, walk_and_one_off):
    env = _switching_env(character, walk_and_one_off, 100.0)  # rare switches, but always at the end
    once = float(env.clip_durations[1])
    env.reset_at(once - 0.5 * env.control_dt, clip=1)
    s = env.step(np.zeros(character.action_size))
    assert not s.done and not s.clip_end and env.motion.clip == 0 and env.time == 0.0


def test_training_switches_into_a_one_off_skill_only_where_a_cycle_ends(character, walk_and_one_off):
    from mjxmimic.envs.skill_switch import maybe_switch_skill

    env = _switching_env(character, walk_and_one_off, 1e-3)  # certain wherever allowed
    walk = float(env.clip_durations[0])
    env.reset_at(0.3 * walk)
    sim = env.physics.kinematics(env.data.qpos, env.data.qvel)
    mid = maybe_switch_skill(env.spec, env.motion, np.float32(0.2 * walk), env.data.qpos,
                             np.zeros((), bool), np, sim)
    assert int(mid.clip) == 0
    end = maybe_switch_skill(env.spec, env.motion._replace(time=np.float32(1.01 * walk)),
                             np.float32(0.99 * walk), env.data.qpos, np.zeros((), bool), np, sim)
    assert int(end.clip) == 1 and float(end.time) == 0.0


def test_nearest_entry_enters_where_the_reference_pose_is_nearest(character, two_clips):
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.observations": SKILLED,
                                            "env.skill_switch_entry": "nearest"})
    env = CpuEnv(config, character, two_clips)
    t = 12 * env.control_dt  # a grid time of the squat
    env.reset_at(t, clip=1)  # the character in the squat's reference state at t
    env.switch(0)
    assert env.motion.clip == 0
    env.switch(1)  # no step in between: the squat's nearest pose is the one the character is in
    assert env.motion.clip == 1 and env.time == pytest.approx(t, abs=1e-6)
    with pytest.raises(config_lib.UserError, match="env.skill_switch_entry"):
        config_lib.make_config("cpu", {"env.skill_switch_entry": "closest"})


def test_a_switch_settles_before_the_pose_rule_applies(character, two_clips):
    from mjxmimic.task import termination

    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.observations": SKILLED,
                                            "env.skill_switch_settle_s": 0.2, "env.pose_termination_m": 0.05})
    env = CpuEnv(config, character, two_clips)
    env.terminations = termination.training_list(0.05)  # training's rules: a body 5 cm off ends it
    env.reset_at(0.1)
    env.switch(1)
    assert env.motion.settle == 6  # 0.2 s of 30 Hz control steps
    for k in range(6):
        s = env.step(np.ones(character.action_size))  # far from the squat
        assert not s.failed and env.motion.settle == 5 - k
        ref, _ = env.reference(env.time)  # the reference root follows the character
        np.testing.assert_allclose(ref[0:2], env.data.qpos[0:2], atol=1e-6)
    settled = env.motion.root_offset.copy()
    s = env.step(np.ones(character.action_size))
    assert s.failed and s.metrics["lost_track"] == 1.0  # the rule applies again
    np.testing.assert_array_equal(env.motion.root_offset, settled)  # the offset is kept from here on
    with pytest.raises(config_lib.UserError, match="env.skill_switch_settle_s"):
        config_lib.make_config("cpu", {"env.skill_switch_settle_s": -1.0})


def test_skill_switching_is_training_only_and_needs_the_skill_observation():
    config = config_lib.make_config("cpu", {"env.observations": SKILLED, "env.skill_switch_s": 2.0})
    assert config_lib.evaluation_config(config).env.skill_switch_s == 0.0
    with pytest.raises(config_lib.UserError, match="env.skill_switch_s"):
        config_lib.make_config("cpu", {"env.skill_switch_s": 2.0})


def test_play_grades_every_clip(skilled_file, capsys):
    assert cli.main(["play", str(skilled_file), "--episodes", "2", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["clips"]
    assert set(rows) == {"slow_walk", "squat"}
    assert all(0 <= r["nr"] <= 1 and r["episodes"] == 2 and r["mjx_nr"] is None for r in rows.values())
    assert cli.main(["play", str(skilled_file), "--clip", "squat", "--episodes", "1", "--json"]) == 0
    assert set(json.loads(capsys.readouterr().out)["clips"]) == {"squat"}
    assert cli.main(["play", str(skilled_file), "--clip", "squat", "--grid", "1.0", "--json"]) == 0
    [row] = json.loads(capsys.readouterr().out)["clips"].values()
    assert row["starts"] == "a grid over the clip, every 1 s" and row["episodes"] == 2  # the squat lasts 2 s
    assert sum(n for _, _, n in row["fall_windows"]) == round(row["fall_rate"] * 2)


def test_skill_sequence(skilled_file, capsys):
    assert cli.main(["play", str(skilled_file), "--skill-sequence", "slow_walk:0.3, squat:0.2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["seconds"] == pytest.approx(0.5)
    first = out["segments"][0]
    assert first["skill"] == "slow_walk" and 0 < first["survived_s"] <= 0.3 + 1e-9
    if not out["fell"]:
        assert [s["skill"] for s in out["segments"]] == ["slow_walk", "squat"]
        assert out["survived_s"] == pytest.approx(0.5, abs=0.04)


@pytest.mark.parametrize("text, message", [
    ("walk:4", "unknown skill 'walk' (the policy's skills: slow_walk, squat)"),
    ("slow_walk", "expected SKILL:SECONDS"),
    ("slow_walk:-1", "the seconds must be a positive number"),
    ("slow_walk:soon", "the seconds must be a positive number"),
])
def test_bad_sequences_are_one_line(skilled_file, capsys, text, message):
    assert cli.main(["play", str(skilled_file), "--skill-sequence", text]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err


def test_a_sequence_needs_several_clips_and_the_skill_observation(tmp_path, character, two_clips, capsys):
    one = policy_file.write_npz(_random_policy(character, two_clips[:1], "phase,root_height,bodies"),
                                tmp_path / "one.npz")
    assert cli.main(["play", str(one), "--skill-sequence", "slow_walk:1"]) == 2
    assert "needs a policy trained on a dataset" in capsys.readouterr().err
    blind = policy_file.write_npz(_random_policy(character, two_clips, "phase,root_height,bodies"),
                                  tmp_path / "blind.npz")
    assert cli.main(["play", str(blind), "--skill-sequence", "slow_walk:1"]) == 2
    assert "does not observe a skill" in capsys.readouterr().err


@pytest.mark.parametrize("entry", ["phase", "nearest"])
def test_switch_trials(skilled_file, capsys, entry):
    assert cli.main(["play", str(skilled_file), "--switch-trials", "2", "--switch-entry", entry, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["pairs"]) == {"slow_walk -> squat", "squat -> slow_walk"} and out["trials"] == 4
    assert out["entry"] == entry and out["lead_s"] == 1.0
    hold = round(out["hold_s"] * 30)
    for row in out["pairs"].values():
        steps = row["steps_after_switch"]
        assert len(steps) == 2 and all(-1 <= x <= hold for x in steps)
        assert row["held"] == sum(x == hold for x in steps)
    assert out["held"] == sum(row["held"] for row in out["pairs"].values())


def test_switch_trials_errors_are_one_line(skilled_file, tmp_path, character, two_clips, capsys):
    assert cli.main(["play", str(skilled_file), "--switch-trials", "0"]) == 2
    assert "--switch-trials 0: must be at least 1" in capsys.readouterr().err
    assert cli.main(["play", str(skilled_file), "--switch-trials", "2", "--switch-lead", "-1"]) == 2
    assert "--switch-lead -1.0: must be at least 0" in capsys.readouterr().err
    assert cli.main(["play", str(skilled_file), "--switch-trials", "1", "--switch-lead", "0.5", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["lead_s"] == 0.5
    one = policy_file.write_npz(_random_policy(character, two_clips[:1], "phase,root_height,bodies"),
                                tmp_path / "one.npz")
    assert cli.main(["play", str(one), "--switch-trials", "1"]) == 2
    assert "--switch-trials needs a policy trained on a dataset" in capsys.readouterr().err


def _trials(rates: dict[str, float]) -> dict:
    """`--switch-trials 10 --json`'s shape with the given hold rates."""
    held = {pair: round(10 * r) for pair, r in rates.items()}
    return {"pairs": {pair: {"held": n, "steps_after_switch": [120] * n + [5] * (10 - n)} for pair, n in held.items()}}


def test_best_routes_pass_through_a_skill_where_that_holds_more_often():
    from mjxmimic.portable.skills import best_routes

    names = ["walk", "run", "backflip"]
    trials = _trials({"walk -> run": 1.0, "walk -> backflip": 1.0, "run -> walk": 0.7, "run -> backflip": 0.0,
                      "backflip -> walk": 0.7, "backflip -> run": 0.2})
    assert best_routes(trials, names) == {(1, 2): 0, (2, 1): 0}  # run <-> backflip through walk
    with pytest.raises(config_lib.UserError, match="pair 'walk -> fly' is not a switch between"):
        best_routes(_trials({"walk -> fly": 1.0}), names)
    with pytest.raises(config_lib.UserError, match="no switch pairs"):
        best_routes({}, names)
    with pytest.raises(config_lib.UserError, match="pair 'walk -> run' has no 'held' count"):
        best_routes({"pairs": {"walk -> run": [10, 10]}}, names)


@pytest.fixture(scope="module")
def three_clips(character, two_clips):
    return [*two_clips, load_clip_source("wave", character)]


def test_a_routed_switch_plays_the_skill_between_for_a_second(character, three_clips):
    from mjxmimic.envs.cpu_env import ROUTE_VIA_S

    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.observations": SKILLED})
    env = CpuEnv(config, character, three_clips)
    env.terminations = ()  # no falls: this is about the order of the skills
    env.routes = {(0, 1): 2}
    env.reset_at(0.3)
    obs = env.switch(1)
    assert env.motion.clip == 2 and list(obs[-3:]) == [0.0, 0.0, 1.0]  # the wave first
    steps = round(ROUTE_VIA_S / env.control_dt)
    clips = []
    for _ in range(steps):
        env.step(np.zeros(character.action_size))
        clips.append(int(env.motion.clip))
    assert clips == [2] * (steps - 1) + [1]  # then the squat
    env.switch(0)  # no route asked for: at once
    assert env.motion.clip == 0


def test_a_switch_out_of_a_finish_cycle_skill_waits_for_its_cycle_end(character, three_clips):
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.observations": SKILLED})
    env = CpuEnv(config, character, three_clips)
    env.terminations = ()
    env.finish_cycle = {0}
    duration = float(env.clip_durations[0])
    env.reset_at(duration - 0.2)
    env.switch(2)
    times = []
    while env.motion.clip == 0:
        times.append(float(env.time))
        env.step(np.zeros(character.action_size))
    assert duration - 2 * env.control_dt < times[-1] < duration  # the wave once the walk's cycle ended
    env.switch(0)  # out of the wave: at once
    assert env.motion.clip == 0


def test_auto_finish_cycle_picks_the_cyclic_skills_that_leave_the_ground(character, three_clips):
    from mjxmimic.portable.skills import AIRBORNE_M, finish_cycle_skills

    walk = three_clips[0]
    lifted = walk.qpos.copy()
    lifted[::2, 2] += AIRBORNE_M + 0.1  # every other frame in the air, both feet well off the floor
    hop = dataclasses.replace(walk, name="hop", qpos=lifted)
    hop_once = dataclasses.replace(hop, name="hop_once", loop=False)
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.observations": SKILLED})
    env = CpuEnv(config, character, [*three_clips, hop, hop_once])
    assert finish_cycle_skills(env, None) == finish_cycle_skills(env, "auto") == {3}  # a one-off waits anyway
    assert finish_cycle_skills(env, "none") == set()
    assert finish_cycle_skills(env, "wave, hop") == {2, 3}


def test_switch_routes_and_finish_cycle_on_the_command_line(tmp_path, character, three_clips, capsys):
    three = policy_file.write_npz(_random_policy(character, three_clips, SKILLED), tmp_path / "three.npz")
    routes = tmp_path / "trials.json"
    routes.write_text(json.dumps(_trials({"slow_walk -> squat": 0.1, "slow_walk -> wave": 0.9,
                                          "wave -> squat": 0.9, "squat -> slow_walk": 1.0})))
    assert cli.main(["play", str(three), "--switch-trials", "1", "--switch-routes", str(routes), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["routes"] == {"slow_walk -> squat": "wave"}
    for flag, expected in (([], []), (["--finish-cycle", "wave"], ["wave"]), (["--finish-cycle", "none"], [])):
        assert cli.main(["play", str(three), "--switch-trials", "1", *flag, "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["finish_cycle"] == expected  # auto: none of these hops
    for command in (["play", str(three), "--switch-trials", "1"],
                    ["render", str(three), "--skill-sequence", "slow_walk:1", "--out", str(tmp_path / "v.mp4")]):
        assert cli.main([*command, "--finish-cycle", "fly"]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "--finish-cycle 'fly': no skill 'fly'" in err
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2")
    for command in (["play", str(three), "--switch-trials", "1"],
                    ["render", str(three), "--skill-sequence", "slow_walk:1", "--out", str(tmp_path / "v.mp4")]):
        assert cli.main([*command, "--switch-routes", str(bad)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "--switch-routes" in err and "cannot read it as JSON" in err
    assert not (tmp_path / "v.mp4").exists()


def test_parse_sequence():
    assert parse_sequence("a:1,b:2.5,a:0.5", ["a", "b"]) == [(0, 1.0), (1, 2.5), (0, 0.5)]


def test_render_a_skill_sequence(skilled_file, tmp_path, headless_video):
    from mjxmimic.portable.render import render_policy

    pf = policy_file.read(skilled_file)
    info = render_policy(pf, tmp_path / "skills.mp4", skill_sequence="slow_walk:0.2,squat:0.2", width=160, height=128)
    steps = 2 * round(0.2 * pf.config().env.control_hz)
    assert info["skill_sequence"] == "slow_walk:0.2,squat:0.2"
    assert info["frames"] == info["steps"] + 1 and (info["fell"] or info["steps"] == steps)


def test_viewer_keys_pick_skills():
    from mjxmimic.portable.skills import skill_for_key

    assert [skill_for_key(ord(k), 3) for k in "1234a"] == [0, 1, 2, None, None]
