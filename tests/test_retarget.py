"""The Unitree G1 character (built from ../shared/robots/unitree_g1) and `clips retarget`."""

import json

import mujoco
import numpy as np
import pytest
from conftest import REPO

from mjxmimic import cli
from mjxmimic.core import g1_character
from mjxmimic.core.character import load_character, resolve_xml
from mjxmimic.motion import retarget
from mjxmimic.motion.clip import load_clip, load_clip_source

G1_DIR = REPO.parent / "shared" / "robots" / "unitree_g1"


@pytest.fixture
def g1_env(monkeypatch, tmp_path):
    """The G1 source named explicitly and the character cache in a temporary folder."""
    if not (G1_DIR / "g1.xml").is_file():
        pytest.skip("../shared/robots/unitree_g1 is not present")
    monkeypatch.setenv("MJXMIMIC_G1", str(G1_DIR))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    return tmp_path


@pytest.fixture
def g1(g1_env):
    return load_character(resolve_xml("g1"))


def test_g1_character(g1):
    assert g1.action_size == 29 and all(j.kind == "hinge" for j in g1.joints)
    assert g1.clip_prefix == "g1_"
    assert abs(g1.mass - 33.34) < 0.01
    joints = {j.name: j for j in g1.joints}
    omega = g1_character.NATURAL_FREQUENCY
    knee = joints["left_knee_joint"]
    assert knee.torque_limit == 139.0 and joints["left_wrist_pitch_joint"].torque_limit == 5.0
    assert joints["left_ankle_roll_joint"].torque_limit == 50.0 and joints["waist_yaw_joint"].torque_limit == 88.0
    armature = g1.model.dof_armature[knee.dof_adr]
    assert armature == pytest.approx(0.025101925)
    assert knee.kp == pytest.approx(armature * omega**2)
    assert knee.kd == pytest.approx(2 * g1_character.DAMPING_RATIO * armature * omega)
    names = {g1.model.body(b).name for b in g1.end_effectors}
    assert names == {"left_ankle_roll_link", "right_ankle_roll_link", "left_wrist_yaw_link", "right_wrist_yaw_link"}
    falls = {g1.model.body(b).name for b in g1.fall_bodies("all-feet")}
    assert "pelvis" in falls and "torso_link" in falls and "left_ankle_roll_link" not in falls
    # self-contained (no meshes, so an exported policy can carry it), with a floor
    text = g1.xml_path.read_text()
    model = mujoco.MjModel.from_xml_string(text)
    assert model.nmesh == 0 and mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor") >= 0


def test_g1_is_rebuilt_only_when_it_changes(g1_env):
    path = resolve_xml("g1")
    stamp = path.stat().st_mtime_ns
    assert resolve_xml("g1") == path and path.stat().st_mtime_ns == stamp
    path.write_text("stale")
    assert resolve_xml("g1").read_text().startswith("<!-- Made by mjxmimic.core.g1_character")


def test_g1_without_its_model_is_one_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("MJXMIMIC_G1", str(tmp_path / "nowhere"))
    assert cli.main(["clips", "list", "--character", "g1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "MJXMIMIC_G1" in err and "no g1.xml" in err


def test_solver_recovers_a_pose_from_its_own_kinematics(g1):
    """Goals made from a G1 motion (every jointed body's orientation, the feet's and hands'
    positions) are met by that motion: frame by frame, warm-started, the solver finds it again."""
    model, data = g1.model, mujoco.MjData(g1.model)
    rng = np.random.default_rng(0)
    frames = 20
    end = model.qpos0.copy()
    for j in g1.joints:
        low, high = model.jnt_range[model.dof_jntid[j.dof_adr]]
        end[j.qpos_adr] = rng.uniform(low + 0.2 * (high - low), high - 0.2 * (high - low))
    qpos = model.qpos0 + np.linspace(0.0, 1.0, frames)[:, None] * (end - model.qpos0)
    qpos[:, 0] = np.linspace(0.0, 0.5, frames)
    bodies = np.array(sorted({j.body for j in g1.joints} | {1}))
    ends = np.array(g1.end_effectors)
    rot, pos = np.zeros((frames, len(bodies), 4)), np.zeros((frames, len(ends), 3))
    for f in range(frames):
        data.qpos[:] = qpos[f]
        mujoco.mj_kinematics(model, data)
        rot[f], pos[f] = data.xquat[bodies], data.xpos[ends]
    goals = retarget._Goals(bodies, rot, np.ones(len(bodies)), ends, pos, np.ones(len(ends)), (),
                            np.tile(model.qpos0[:7], (frames, 1)))
    solved = retarget._solve(g1, goals, iterations=100)
    np.testing.assert_allclose(solved[:, 7:], qpos[:, 7:], atol=2e-3)
    np.testing.assert_allclose(solved[:, 0:3], qpos[:, 0:3], atol=2e-3)


def test_walk_onto_the_g1(g1, deepmimic_dir):
    humanoid = load_character()
    clip = load_clip_source("walk", humanoid, deepmimic_dir / "motions")
    result = retarget.retarget(clip, humanoid, g1, retarget.find_map("humanoid", "g1"))
    report, out = result.report, result.clip
    assert report["method"] == "ik" and out.num_frames == clip.num_frames and out.loop
    assert 0.75 < report["scale"] < 0.85  # the G1's leg against the humanoid's
    assert max(report["end_effector_error_m"].values()) < 0.06
    assert report["frames_below_ground"] == 0 and report["foot_skating_m_per_s"] < 0.1
    model = g1.model
    for j in g1.joints:  # every hinge within its range
        low, high = model.jnt_range[model.dof_jntid[j.dof_adr]]
        assert np.all(out.qpos[:, j.qpos_adr] >= low - 1e-9) and np.all(out.qpos[:, j.qpos_adr] <= high + 1e-9)
    assert out.root_travel == pytest.approx(report["scale"] * clip.root_travel, rel=0.1)


def test_matching_skeletons_copy_the_joints(character, deepmimic_dir):
    clip = load_clip_source("walk", character, deepmimic_dir / "motions")
    result = retarget.retarget(clip, character, character)
    assert result.report["method"] == "copy" and result.report["scale"] == pytest.approx(1.0)
    np.testing.assert_allclose(result.clip.qpos[:, 3:], clip.qpos[:, 3:])


def test_retarget_cli(g1_env, deepmimic_dir, capsys):
    out = g1_env / "g1_walk.txt"
    motions = str(deepmimic_dir / "motions")
    assert cli.main(["clips", "retarget", "walk", "--to", "g1", "--out", str(out), "--clips-dir", motions,
                     "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["to"] == "g1" and report["method"] == "ik" and report["clip"] == str(out)
    assert set(report) >= {"end_effector_error_m", "foot_skating_m_per_s", "penetration_max_m", "joint_limit_hits"}
    assert load_clip(out, load_character(resolve_xml("g1"))).num_frames == report["frames"]
    # the clip is found by its short name for the G1 (clip prefix g1_)
    assert cli.main(["clips", "info", "walk", "--character", "g1", "--clips-dir", str(g1_env)]) == 0
    assert "valid" in capsys.readouterr().out


def test_bvh_import_onto_the_g1_goes_through_the_humanoid(g1_env, capsys):
    """`clips import --character g1`: no skeleton mapping names the G1, so the motion is imported
    onto the humanoid and retargeted, the same clip as the two commands one after the other."""
    from test_bvh import bvh_text, walking_frames

    source = g1_env / "walk.bvh"
    source.write_text(bvh_text(walking_frames()))
    out, humanoid_clip, two_steps = g1_env / "g1_walk.txt", g1_env / "humanoid_walk.txt", g1_env / "g1_walk2.txt"
    assert cli.main(["clips", "import", str(source), "--character", "g1", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["via"] == "humanoid" and report["method"] == "ik"
    assert report["import"]["mapping"].endswith("cmu_mb.json")
    assert cli.main(["clips", "import", str(source), "--out", str(humanoid_clip)]) == 0
    assert cli.main(["clips", "retarget", str(humanoid_clip), "--to", "g1", "--out", str(two_steps)]) == 0
    g1 = load_character(resolve_xml("g1"))
    np.testing.assert_allclose(load_clip(out, g1).qpos, load_clip(two_steps, g1).qpos, atol=1e-9)
    capsys.readouterr()
    assert cli.main(["clips", "import", str(source), "--character", "dog3d", "--out", str(g1_env / "dog.txt")]) == 2
    err = capsys.readouterr().err.strip()
    assert "no skeleton mapping moves dog3d" in err and "\n" not in err


@pytest.mark.parametrize("content, message", [
    ("{", "is not JSON"),
    ('{"orientations": {}, "positions": {}, "scale_chain": {"target": ["a", "b"], "source": ["c", "d"]}}',
     "'orientations' must map"),
    ('{"orientations": {}, "positions": {}, "scale_chain": {}}', "scale_chain must be"),
    ('{"orientations": {"pelvis": ["root", -1]}, "positions": {"pelvis": ["root", 1]}, '
     '"scale_chain": {"target": ["a", "b"], "source": ["c", "d"]}}', "orientations.pelvis: expected"),
    ('{"bodies": {}}', "unknown key 'bodies'"),
    ('{"orientations": {"pelvis": ["nobody", 1]}, "positions": {"pelvis": ["root", 1]}, '
     '"scale_chain": {"target": ["left_hip_pitch_link", "left_knee_link"], "source": ["left_hip", "left_knee"]}}',
     "humanoid has no body 'nobody'"),
])
def test_bad_retarget_files_are_one_line(g1_env, deepmimic_dir, capsys, content, message):
    bad = g1_env / "map.json"
    bad.write_text(content)
    out = g1_env / "out.txt"
    assert cli.main(["clips", "retarget", "walk", "--to", "g1", "--out", str(out), "--map", str(bad),
                     "--clips-dir", str(deepmimic_dir / "motions")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err and str(bad) in err
    assert not out.exists()


def test_no_retarget_file_for_the_dog(deepmimic_dir, tmp_path, capsys):
    out = tmp_path / "dog_walk.txt"
    assert cli.main(["clips", "retarget", "walk", "--to", "dog3d", "--out", str(out),
                     "--clips-dir", str(deepmimic_dir / "motions")]) == 2
    assert "no retarget file for humanoid -> dog3d" in capsys.readouterr().err
    assert not out.exists()


def test_g1_steps_on_mujoco_c(g1, deepmimic_dir):
    """The G1, held on its retargeted walk by PD targets at the reference (residual action 0),
    walks a few control steps on MuJoCo C without falling: gains, limits and foot contacts are sane."""
    from mjxmimic.core.config import make_config
    from mjxmimic.envs.cpu_env import CpuEnv

    humanoid = load_character()
    walk = load_clip_source("walk", humanoid, deepmimic_dir / "motions")
    clip = retarget.retarget(walk, humanoid, g1, retarget.find_map("humanoid", "g1")).clip
    env = CpuEnv(make_config("cpu", {"env.action_mode": "residual"}), g1, clip)
    obs = env.reset_at(0.1)
    assert obs.shape == (env.observation_size,) and env.action_size == 29
    rewards = []
    for _ in range(10):
        step = env.step(np.zeros(env.action_size))
        assert np.all(np.isfinite(step.obs)) and not step.fell
        rewards.append(step.reward)
    assert min(rewards) > 0.5
