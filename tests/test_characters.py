"""Characters as data: the DeepMimic character converter, the shipped dog, names and clip prefixes."""

import json

import mujoco
import numpy as np
import pytest

from mjxmimic import cli
from mjxmimic.core import deepmimic_character
from mjxmimic.core.character import (XML_DIR, character_names, character_prefixes, load_character,
                                     resolve_xml)
from mjxmimic.core.errors import UserError
from mjxmimic.motion.clip import load_clip, resolve_clip


def _convert(deepmimic_dir, name: str) -> str:
    data = json.loads((deepmimic_dir / "characters" / f"{name}.txt").read_text())
    return deepmimic_character.convert(data, name, source=f"{name}.txt")


def test_shipped_dog_is_the_converter_output(deepmimic_dir):
    assert (XML_DIR / "dog3d.xml").read_text() == _convert(deepmimic_dir, "dog3d")


def test_converted_humanoid_matches_the_hand_made_one(deepmimic_dir, tmp_path):
    """The converter reproduces the humanoid that was built and checked by hand, number for number
    (all but the root's start height, which the first reset replaces)."""
    (tmp_path / "humanoid3d.xml").write_text(_convert(deepmimic_dir, "humanoid3d"))
    ours = mujoco.MjModel.from_xml_path(str(tmp_path / "humanoid3d.xml"))
    hand = mujoco.MjModel.from_xml_path(str(XML_DIR / "humanoid.xml"))
    for field in ("body_mass", "body_inertia", "body_ipos", "body_parentid", "body_quat", "jnt_type",
                  "jnt_range", "jnt_limited", "dof_damping", "geom_type", "geom_size", "geom_pos",
                  "geom_quat", "geom_bodyid"):
        np.testing.assert_allclose(getattr(ours, field), getattr(hand, field), atol=1e-6, err_msg=field)
    np.testing.assert_allclose(ours.body_pos[2:], hand.body_pos[2:], atol=1e-6)
    names = [mujoco.mj_id2name(hand, mujoco.mjtObj.mjOBJ_NUMERIC, i) for i in range(hand.nnumeric)]
    for name in names:
        i, j = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_NUMERIC, name) for m in (ours, hand))
        assert i >= 0, name
        a = ours.numeric_data[ours.numeric_adr[i]:ours.numeric_adr[i] + ours.numeric_size[i]]
        b = hand.numeric_data[hand.numeric_adr[j]:hand.numeric_adr[j] + hand.numeric_size[j]]
        np.testing.assert_allclose(a, b, err_msg=name)


def test_dog_character():
    dog = load_character(resolve_xml("dog3d"))
    assert dog.clip_prefix == "dog3d_"
    assert dog.action_size == 58  # 18 ball joints (3 each) and 4 hinges
    assert abs(dog.mass - 29.25) < 0.01
    names = {mujoco.mj_id2name(dog.model, mujoco.mjtObj.mjOBJ_BODY, b) for b in dog.fall_bodies("all-feet")}
    assert names.isdisjoint({"left_finger", "right_finger", "left_toe", "right_toe"})
    assert {"root", "spine0", "head", "tail1", "left_foot"} <= names
    # every foot touches the ground through its four sole spheres
    feet = [g for g in range(dog.model.ngeom) if dog.model.geom_size[g][0] == deepmimic_character.SOLE_RADIUS]
    assert len(feet) == 16


def test_names_prefixes_and_resolution(tmp_path):
    assert {"humanoid", "dog3d"} <= set(character_names())
    assert character_prefixes()["humanoid"] == "humanoid3d_"
    assert character_prefixes()["dog3d"] == "dog3d_"
    assert resolve_xml("dog3d") == XML_DIR / "dog3d.xml"
    assert resolve_xml("dog3d.xml") == XML_DIR / "dog3d.xml"
    own = tmp_path / "mine.xml"
    own.write_text((XML_DIR / "dog3d.xml").read_text())
    assert resolve_xml(own) == own
    with pytest.raises(UserError, match="unknown character 'cat': not a file, and not one of dog3d, g1, humanoid"):
        resolve_xml("cat")


def test_dog_clips_by_short_name(deepmimic_dir):
    dog = load_character(resolve_xml("dog3d"))
    path = resolve_clip("trot", str(deepmimic_dir / "motions"), dog.clip_prefix)
    assert path.name == "dog3d_trot.txt"
    clip = load_clip(path, dog)
    assert clip.qpos.shape[1] == dog.nq
    assert clip.loop


def test_clips_cli_with_the_dog(deepmimic_dir, capsys):
    motions = str(deepmimic_dir / "motions")
    assert cli.main(["clips", "list", "--character", "dog3d", "--clips-dir", motions]) == 0
    rows = {line.split()[0]: line.split() for line in capsys.readouterr().out.splitlines()[1:]}
    assert rows["trot"][2] == "dog3d" and rows["canter"][2] == "dog3d"
    assert cli.main(["clips", "info", "trot", "--character", "dog3d", "--clips-dir", motions, "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["valid"] and info["path"].endswith("dog3d_trot.txt")
    # the humanoid does not read the dog's clip, and says whose it is
    assert cli.main(["clips", "info", str(deepmimic_dir / "motions" / "dog3d_trot.txt")]) == 2
    err = capsys.readouterr().err
    assert "dog3d_trot.txt" in err and err.strip().endswith("(a clip of dog3d: --character dog3d)")


def test_unknown_character_is_one_line(capsys):
    assert cli.main(["clips", "list", "--character", "cat"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "unknown character 'cat'" in err


def test_converter_errors(tmp_path, capsys):
    bad = tmp_path / "bad.txt"
    bad.write_text("{not json")
    assert deepmimic_character.main([str(bad)]) == 2
    assert "bad.txt: the character file is not JSON" in capsys.readouterr().err
    odd = tmp_path / "odd.txt"
    odd.write_text(json.dumps({"Skeleton": {"Joints": [
        {"ID": 0, "Name": "root", "Type": "none", "Parent": -1, "AttachX": 0, "AttachY": 0, "AttachZ": 0},
        {"ID": 1, "Name": "wing", "Type": "revolute", "Parent": 0, "AttachX": 0, "AttachY": 1, "AttachZ": 0,
         "LimLow0": -1, "LimHigh0": 1, "TorqueLim": 10, "DiffWeight": 1}]}, "BodyDefs": [], "DrawShapeDefs": []}))
    out = tmp_path / "odd.xml"
    assert deepmimic_character.main([str(odd), "--out", str(out)]) == 2
    assert "odd: no built-in PD gains (known: humanoid3d, dog3d); pass --ctrl" in capsys.readouterr().err
    assert deepmimic_character.main([str(odd), "--name", "dog3d", "--out", str(out)]) == 2
    assert "no PD gains for joint 'wing'" in capsys.readouterr().err
    assert not out.exists()


def test_dog_steps_on_mujoco_c(deepmimic_dir):
    """The dog, held on its trot by PD targets at the reference (residual action 0), stands for a
    few control steps on MuJoCo C: its bodies, gains and sole contacts make a sane simulation."""
    from mjxmimic.core.config import make_config
    from mjxmimic.envs.cpu_env import CpuEnv

    dog = load_character(resolve_xml("dog3d"))
    clip = load_clip(resolve_clip("trot", str(deepmimic_dir / "motions"), dog.clip_prefix), dog)
    env = CpuEnv(make_config("cpu", {"env.action_mode": "residual"}), dog, clip)
    obs = env.reset_at(0.1)
    assert obs.shape == (env.observation_size,) and env.action_size == dog.action_size
    rewards = []
    for _ in range(10):
        step = env.step(np.zeros(env.action_size))
        assert np.all(np.isfinite(step.obs)) and not step.fell
        rewards.append(step.reward)
    assert min(rewards) > 0.5  # still near the trot a third of a second later


def test_a_file_that_is_no_character_is_one_line(tmp_path):
    from mjxmimic.core.character import load_character
    from mjxmimic.core.errors import UserError

    cases = {"text.xml": "not xml", "no_root.xml": '<mujoco><worldbody><body><geom size="1"/></body></worldbody></mujoco>',
             "no_custom.xml": '<mujoco><worldbody><body><freejoint/><geom size="1"/></body></worldbody></mujoco>'}
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
        with pytest.raises(UserError) as err:
            load_character(tmp_path / name)
        assert str(err.value).startswith(f"character {tmp_path / name}: ") and "\n" not in str(err.value), name
    with pytest.raises(UserError, match="first joint must be the root's free joint"):
        load_character(tmp_path / "no_root.xml")
    with pytest.raises(UserError, match="missing from the model's <custom> block"):
        load_character(tmp_path / "no_custom.xml")
    with pytest.raises(UserError, match="character file not found"):
        load_character(tmp_path / "missing.xml")
