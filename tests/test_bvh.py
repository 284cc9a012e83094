"""BVH import: the parser and its errors, forward kinematics, mapping onto the humanoid, the CLI.

The tests write their own small BVH files: a CMU-like skeleton in the MotionBuilder conversion's
joint names (legs resting splayed, arms down, y up, facing +z) walking forward.
"""

import json
import math
import re

import mujoco
import numpy as np
import pytest

from mjxmimic import cli
from mjxmimic.core import quat
from mjxmimic.core.character import load_character
from mjxmimic.core.errors import UserError
from mjxmimic.motion.bvh import BvhError, load_bvh, parse_bvh
from mjxmimic.motion.bvh_import import SKELETONS, find_mapping, import_bvh, load_mapping
from mjxmimic.motion.clip import load_clip

# name, parent, offset (y up, facing +z, +x to the skeleton's left); every joint has ZXY rotations
SKELETON = [
    ("Hips", None, (0, 0, 0)),
    ("LeftUpLeg", "Hips", (9, -5, 0)), ("LeftLeg", "LeftUpLeg", (3, -40, 0)), ("LeftFoot", "LeftLeg", (3, -40, 0)),
    ("RightUpLeg", "Hips", (-9, -5, 0)), ("RightLeg", "RightUpLeg", (-3, -40, 0)),
    ("RightFoot", "RightLeg", (-3, -40, 0)),
    ("Spine", "Hips", (0, 10, 0)), ("Spine1", "Spine", (0, 20, 0)), ("Neck", "Spine1", (0, 20, 0)),
    ("Head", "Neck", (0, 8, 0)),
    ("LeftShoulder", "Spine1", (4, 18, 0)), ("LeftArm", "LeftShoulder", (14, 0, 0)),
    ("LeftForeArm", "LeftArm", (0, -28, 0)), ("LeftHand", "LeftForeArm", (0, -25, 0)),
    ("RightShoulder", "Spine1", (-4, 18, 0)), ("RightArm", "RightShoulder", (-14, 0, 0)),
    ("RightForeArm", "RightArm", (0, -28, 0)), ("RightHand", "RightForeArm", (0, -25, 0)),
]
END_SITES = {"LeftFoot": (0, -5, 15), "RightFoot": (0, -5, 15), "Head": (0, 10, 0), "LeftHand": (0, -8, 0),
             "RightHand": (0, -8, 0)}
NAMES = [name for name, _, _ in SKELETON]
FPS = 30


def bvh_text(frames: np.ndarray, frame_time: float = 1 / FPS, z_up: bool = False) -> str:
    """The BVH file of SKELETON with the given (F, 6 + 3 x 18) channel values; with z_up, the same
    motion in coordinates where z is up and the skeleton faces -y (x, y, z -> x, -z, y)."""
    lines = ["HIERARCHY"]
    rotations = "Zrotation Xrotation Yrotation"
    if z_up:  # about y becomes about z; about z becomes about -y
        frames = frames.copy()
        frames[:, 1], frames[:, 2] = -frames[:, 2], frames[:, 1].copy()
        frames[:, 3::3] *= -1
        rotations = "Yrotation Xrotation Zrotation"

    def block(name: str, depth: int) -> None:
        pad = "  " * depth
        parent = next(p for n, p, _ in SKELETON if n == name)
        offset = next(o for n, _, o in SKELETON if n == name)
        lines.append(f"{pad}{'ROOT' if parent is None else 'JOINT'} {name}")
        lines.append(f"{pad}{{")
        x, y, z = offset
        lines.append(f"{pad}  OFFSET {x} {-z if z_up else y} {y if z_up else z}")
        channels = "6 Xposition Yposition Zposition" if parent is None else "3"
        lines.append(f"{pad}  CHANNELS {channels} {rotations}")
        for child, p, _ in SKELETON:
            if p == name:
                block(child, depth + 1)
        if name in END_SITES:
            x, y, z = END_SITES[name]
            y, z = (-z, y) if z_up else (y, z)
            lines.extend([f"{pad}  End Site", f"{pad}  {{", f"{pad}    OFFSET {x} {y} {z}", f"{pad}  }}"])
        lines.append(f"{pad}}}")

    block("Hips", 0)
    lines += ["MOTION", f"Frames: {len(frames)}", f"Frame Time: {frame_time:.8f}"]
    lines += [" ".join(f"{v:.5f}" for v in row) for row in frames]
    return "\n".join(lines) + "\n"


def column(joint: str, axis: str) -> int:
    """Column of a joint's rotation channel (Z, X or Y) in a frame row."""
    return 3 + 3 * NAMES.index(joint) + "ZXY".index(axis)


def walking_frames(seconds: float = 2.0) -> np.ndarray:
    """Hips moving +z at 100 units/s, thighs swinging about the left axis (x), knees bending,
    the arms swinging, the chest turning a little."""
    t = np.arange(int(seconds * FPS) + 1) / FPS
    frames = np.zeros((len(t), 3 + 3 * len(SKELETON)))
    frames[:, 1], frames[:, 2] = 90.0, 100.0 * t
    swing = 25 * np.sin(2 * np.pi * t)
    for side, sign in (("Left", 1), ("Right", -1)):
        frames[:, column(f"{side}UpLeg", "X")] = sign * swing
        frames[:, column(f"{side}UpLeg", "Z")] = -sign * 5.0  # brings the splayed leg nearly straight
        frames[:, column(f"{side}Leg", "X")] = 30 * (1 + sign * np.cos(2 * np.pi * t))
        frames[:, column(f"{side}Arm", "X")] = -sign * swing
    frames[:, column("Spine1", "Y")] = 10 * np.sin(2 * np.pi * t)
    return frames


@pytest.fixture(scope="module")
def walk_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("bvh") / "walk.bvh"
    path.write_text(bvh_text(walking_frames()))
    return path


# ------------------------------------------------------------------------------------------ parser


def test_parse(walk_file):
    bvh = load_bvh(walk_file)
    assert bvh.names == NAMES and bvh.num_frames == 2 * FPS + 1
    assert bvh.frame_time == 1 / FPS  # the file's 0.03333333 read as 1/30
    assert bvh.joints[0].channels[:3] == ("Xposition", "Yposition", "Zposition")
    assert bvh.joints[NAMES.index("LeftLeg")].parent == NAMES.index("LeftUpLeg")
    np.testing.assert_allclose(bvh.joints[NAMES.index("LeftFoot")].end_site, [0, -5, 15])


def test_rotation_channels_compose_in_the_listed_order(tmp_path):
    frames = np.zeros((1, 3 + 3 * len(SKELETON)))
    frames[0, column("LeftUpLeg", "Z"):column("LeftUpLeg", "Z") + 3] = (10, 20, 30)
    bvh = parse_bvh(bvh_text(frames), tmp_path / "x.bvh")
    expected = np.zeros(4)
    mujoco.mju_euler2Quat(expected, np.radians([10, 20, 30]), "zxy")  # intrinsic z, then x, then y
    np.testing.assert_allclose(bvh.local_rotations()[0, NAMES.index("LeftUpLeg")], expected, atol=1e-12)


def test_forward_kinematics(tmp_path):
    frames = np.zeros((2, 3 + 3 * len(SKELETON)))
    frames[:, :3] = (1, 90, 2)
    frames[1, column("LeftUpLeg", "X")] = 90.0  # thigh about the left axis: its bone turns from down to -z
    bvh = parse_bvh(bvh_text(frames), tmp_path / "x.bvh")
    pos, _ = bvh.forward_kinematics()
    rest = bvh.rest_positions()
    np.testing.assert_allclose(pos[0] - pos[0, 0], rest, atol=1e-9)  # channels zero = the rest pose
    hip, knee = NAMES.index("LeftUpLeg"), NAMES.index("LeftLeg")
    np.testing.assert_allclose(pos[0, hip], [1 + 9, 90 - 5, 2], atol=1e-9)
    np.testing.assert_allclose(pos[1, knee] - pos[1, hip], [3, 0, -40], atol=1e-9)


@pytest.mark.parametrize("edit, message", [
    (lambda t: "", "the file is empty"),
    (lambda t: t.replace("HIERARCHY", "HIERARCHIE"), ":1: expected 'HIERARCHY', found 'HIERARCHIE'"),
    (lambda t: t.replace("OFFSET 3 -40 0", "OFFSET 3 -4o 0"), "LeftLeg's OFFSET: '-4o' is not a number"),
    (lambda t: t.replace("CHANNELS 3 Zrotation", "CHANNELS 3 Wrotation", 1), "unknown channel 'Wrotation'"),
    (lambda t: t.replace("Frames: 3", "Frames: 4"), "expected 4 frames x 60 channels = 240"),
    (lambda t: t.rsplit("\n", 2)[0] + "\n", "expected 3 frames x 60 channels"),
    (lambda t: t.replace("Frame Time: 0.03333333", "Frame Time: 0"), "a frame time of 0 s"),
    (lambda t: t[:t.index("MOTION")], "the file ends where 'MOTION' was expected"),
    (lambda t: t.replace("JOINT Spine\n", "JOINT LeftLeg\n"), "joint 'LeftLeg' is defined twice"),
])
def test_parse_errors_name_the_file_and_line(tmp_path, edit, message):
    path = tmp_path / "bad.bvh"
    path.write_text(edit(bvh_text(np.zeros((3, 60)))))
    with pytest.raises(BvhError, match=None) as err:
        load_bvh(path)
    assert str(err.value).startswith(str(path)) and message in str(err.value), str(err.value)
    assert "\n" not in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(BvhError, match="no such file"):
        load_bvh(tmp_path / "none.bvh")


def test_a_value_that_is_not_a_number(tmp_path):
    text = bvh_text(np.zeros((3, 60)))
    lines = text.splitlines()
    lines[-2] = lines[-2].replace("0.00000", "nan", 1)
    path = tmp_path / "nan.bvh"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(BvhError, match=f"{path}:{len(lines) - 1}: frame 1: a value that is not finite"):
        load_bvh(path)


# ---------------------------------------------------------------------------------------- retarget


@pytest.fixture(scope="module")
def imported(walk_file):
    bvh = load_bvh(walk_file)
    character = load_character()
    return bvh, character, import_bvh(bvh, character, find_mapping(bvh, "humanoid"), fps=60)


def _body_positions(character, qpos):
    data = mujoco.MjData(character.model)
    out = []
    for q in qpos:
        data.qpos[:] = q
        mujoco.mj_kinematics(character.model, data)
        out.append((data.xpos.copy(), data.xquat.copy()))
    return np.array([p for p, _ in out]), np.array([q for _, q in out])


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_bones_point_where_the_source_bones_point(imported):
    """Thighs and upper arms of the humanoid follow the source's bone directions frame by frame
    (source y up, facing +z -> z up, facing +x), although the source's legs rest splayed; the
    shins nearly (the knee hinge turns about the thigh's own axis, which the splay tilts)."""
    bvh, character, result = imported
    assert result.report["mapping"].endswith("cmu_mb.json")  # picked by the joint names
    src, _ = bvh.forward_kinematics()
    to_world = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]])  # rows: world x, y, z in source axes
    # the clip is at 60 fps and the source at 30: every other clip frame is a source frame
    pos, _ = _body_positions(character, result.clip.qpos[::2])
    model = character.model

    def angles(body, child, joint, joint_child):
        b, c = model.body(body).id, model.body(child).id
        target = _unit(pos[:, c] - pos[:, b])
        source = _unit((src[:, NAMES.index(joint_child)] - src[:, NAMES.index(joint)]) @ to_world.T)
        return np.arccos(np.clip(np.sum(target * source, axis=1), -1, 1))

    for bone in [("left_hip", "left_knee", "LeftUpLeg", "LeftLeg"), ("right_hip", "right_knee", "RightUpLeg", "RightLeg"),
                 ("left_shoulder", "left_elbow", "LeftArm", "LeftForeArm")]:
        assert angles(*bone).max() < 1e-3, bone
    shin = angles("right_knee", "right_ankle", "RightLeg", "RightFoot")
    assert shin.max() < 0.05 and shin.mean() < 0.02


def test_root_scale_ground_and_resampling(imported):
    bvh, character, result = imported
    report, clip = result.report, result.clip
    model = character.model
    target_leg = np.linalg.norm(model.body("right_knee").pos) + np.linalg.norm(model.body("right_ankle").pos)
    assert math.isclose(report["scale"], target_leg / (2 * math.hypot(3, 40)), rel_tol=1e-9)
    assert clip.num_frames == 121 and math.isclose(clip.fps, 60.0)
    np.testing.assert_allclose(clip.qpos[0, :2], 0.0, atol=1e-12)  # starts at the origin
    # 100 units/s forward (+z) in the source is scale x 100 m/s along +x
    speed = (clip.qpos[-1, 0] - clip.qpos[0, 0]) / clip.duration
    assert math.isclose(speed, 100 * report["scale"], rel_tol=0.02)
    assert abs(clip.qpos[-1, 1]) < 0.01
    assert report["penetration_max_m"] < 0.02 and report["frames_below_ground"] <= 0.05 * clip.num_frames
    assert report["end_effector_error_m"]["left_ankle"] < 0.03
    assert report["joint_limit_hits"] == 0


def test_hinge_limits_are_kept_and_counted(tmp_path):
    frames = walking_frames()
    frames[:, column("LeftLeg", "X")] = -40.0  # the knee bent the wrong way
    path = tmp_path / "bent.bvh"
    path.write_text(bvh_text(frames))
    bvh = load_bvh(path)
    character = load_character()
    result = import_bvh(bvh, character, find_mapping(bvh, "humanoid"))
    knee = character.model.joint("left_knee")
    assert result.report["joint_limit_hits"] == bvh.num_frames
    angles = result.clip.qpos[:, knee.qposadr[0]]
    assert np.all(angles >= knee.range[0] - 1e-9) and np.all(angles <= knee.range[1] + 1e-9)


def test_mapping_errors(tmp_path, walk_file):
    bvh = load_bvh(walk_file)
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    with pytest.raises(UserError, match="the mapping file is not JSON"):
        load_mapping(bad, "humanoid")
    bad.write_text(json.dumps({"up": "+y", "forward": "+z", "characters": {"humanoid": {"bodies": {}}}}))
    with pytest.raises(UserError, match="scale_chain must list"):
        load_mapping(bad, "humanoid")
    with pytest.raises(UserError, match="no mapping for character 'dog3d'"):
        find_mapping(bvh, "dog3d")
    renamed = tmp_path / "renamed.bvh"
    renamed.write_text(walk_file.read_text().replace("LeftFoot", "Joint7"))
    with pytest.raises(UserError, match=r"no skeleton mapping fits its joints \(tried cmu_max \(no .*cmu_mb \(no "
                                        r"LeftFoot\), a guess from the joint names \(no joint named like a left "
                                        r"foot or ankle\)\); write one like .*cmu_max.json and pass --mapping"):
        find_mapping(load_bvh(renamed), "humanoid")


# Other skeletons' names for SKELETON's joints: Mixamo's (namespaced), Daz's CMU conversion's
# (side letters in front), a game rig's (side letters behind); Neck and the clavicles keep theirs.
RIGS = {
    "mixamo": {n: f"mixamorig:{n}" for n in NAMES},
    "daz": {"Hips": "hip", "Spine": "abdomen", "Spine1": "chest", "Head": "head",
            **{f"{s}{part}": f"{s[0].lower()}{daz}" for s in ("Left", "Right") for part, daz in
               (("UpLeg", "Thigh"), ("Leg", "Shin"), ("Foot", "Foot"), ("Shoulder", "Collar"), ("Arm", "Shldr"),
                ("ForeArm", "ForeArm"), ("Hand", "Hand"))}},
    "game": {"Spine1": "Chest", **{f"{s}{part}": f"{game}_{s[0]}" for s in ("Left", "Right") for part, game in
                                   (("UpLeg", "UpperLeg"), ("Leg", "LowerLeg"), ("Foot", "Foot"),
                                    ("Shoulder", "Clavicle"), ("Arm", "UpperArm"), ("ForeArm", "LowerArm"),
                                    ("Hand", "Hand"))}},
}


def renamed_text(text: str, names: dict[str, str]) -> str:
    return re.sub(r"^(\s*(?:ROOT|JOINT) )(\S+)$", lambda m: m[1] + names.get(m[2], m[2]), text, flags=re.M)


@pytest.mark.parametrize("rig, z_up", [("mixamo", True), ("daz", False), ("game", True)])
def test_a_skeleton_no_mapping_names_is_guessed(imported, tmp_path, rig, z_up):
    """The walk under another rig's joint names, and in z-up coordinates, imports without a
    mapping file into the same clip as through the shipped mapping: the guess finds the same
    joints, and the axes from the rest pose."""
    _, character, expected = imported
    path = tmp_path / f"{rig}.bvh"
    path.write_text(renamed_text(bvh_text(walking_frames(), z_up=z_up), RIGS[rig]))
    bvh = load_bvh(path)
    mapping = find_mapping(bvh, "humanoid")
    shipped = load_mapping(SKELETONS / "cmu_mb.json", "humanoid")
    assert mapping.path is None and mapping.bodies == {b: RIGS[rig].get(j, j) for b, j in shipped.bodies.items()}
    result = import_bvh(bvh, character, mapping, fps=60)
    assert result.report["mapping"] == "guessed from the joint names"
    np.testing.assert_allclose(result.clip.qpos, expected.clip.qpos, atol=1e-6)


def folded(frames: np.ndarray, seed: int = 0) -> tuple[list, dict, np.ndarray]:
    """SKELETON and the walk's channel values rewritten for other joint frames (each joint's turned
    by a random constant rotation C, as LAFAN1's differ from an upright rest pose): the same world
    motion, with a rest pose that lies in a heap. Local rotations become C_parent^-1 L C, offsets
    C_parent^-1 o."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    turn = {name: Rotation.random(random_state=rng) for name in NAMES}
    parent_turn = {n: turn[p] if p else Rotation.identity() for n, p, _ in SKELETON}
    skeleton = [(n, p, tuple(np.round(parent_turn[n].inv().apply(o), 9))) for n, p, o in SKELETON]
    ends = {n: tuple(np.round(turn[n].inv().apply(o), 9)) for n, o in END_SITES.items()}
    out = frames.copy()
    for name in NAMES:
        cols = [column(name, axis) for axis in "ZXY"]
        local = Rotation.from_euler("ZXY", frames[:, cols], degrees=True)
        out[:, cols] = (parent_turn[name].inv() * local * turn[name]).as_euler("ZXY", degrees=True)
    return skeleton, ends, out


@pytest.mark.parametrize("rig", [None, "mixamo"])
def test_a_rest_pose_that_does_not_stand_is_calibrated_on_the_recording(imported, tmp_path, monkeypatch, rig):
    """Joint frames of another convention, whose rest pose does not stand: the bones are matched
    at the recording's frame nearest the character's rest pose instead (through cmu_mb's names, or
    a guess whose axes come from the motion), and the clip comes out as from the upright file."""
    _, character, expected = imported
    skeleton, ends, frames = folded(walking_frames())
    monkeypatch.setitem(globals(), "SKELETON", skeleton)
    monkeypatch.setitem(globals(), "END_SITES", ends)
    path = tmp_path / "folded.bvh"
    text = bvh_text(frames)
    path.write_text(renamed_text(text, RIGS[rig]) if rig else text)
    bvh = load_bvh(path)
    result = import_bvh(bvh, character, find_mapping(bvh, "humanoid"), fps=60)
    calibration = result.report["calibration"]
    assert isinstance(calibration, dict) and calibration["bone_angle_rad"] < 0.3
    got, _ = _body_positions(character, result.clip.qpos)
    want, _ = _body_positions(character, expected.clip.qpos)
    error = np.linalg.norm((got - got[:, 1:2]) - (want - want[:, 1:2]), axis=-1)  # about the root
    assert error.max() < 0.01 and error.mean() < 0.002, (error.max(), error.mean())
    np.testing.assert_allclose(result.clip.qpos[:, :3], expected.clip.qpos[:, :3], atol=0.01)


def test_the_guess_needs_a_standing_rest_pose(tmp_path):
    text = bvh_text(walking_frames()).replace("OFFSET 0 20 0\n", "OFFSET 0 -80 0\n", 1)  # Spine1 below the hips
    path = tmp_path / "upside_down.bvh"
    path.write_text(renamed_text(text, RIGS["mixamo"]))
    with pytest.raises(UserError, match=r"a guess from the joint names \(neither its rest pose nor its motion "
                                        r"stands"):
        find_mapping(load_bvh(path), "humanoid")


# --------------------------------------------------------------------------------------------- CLI


def test_import_command(walk_file, tmp_path, capsys):
    out = tmp_path / "walk.txt"
    assert cli.main(["clips", "import", str(walk_file), "--out", str(out), "--start", "0.5", "--end", "1.5",
                     "--fps", "30", "--loop", "wrap", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["frames"] == 31 and report["clip"] == str(out)
    clip = load_clip(out, load_character())
    assert clip.loop and clip.num_frames == 31 and math.isclose(clip.duration, 1.0, rel_tol=1e-6)
    assert cli.main(["clips", "info", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["valid"]


def test_import_command_shows_a_guessed_mapping_as_a_file(walk_file, tmp_path, capsys):
    """What the guess chose is printed, and --json gives it as a mapping file that imports the
    same clip when passed back with --mapping."""
    source = tmp_path / "mixamo.bvh"
    source.write_text(renamed_text(walk_file.read_text(), RIGS["mixamo"]))
    out = tmp_path / "guessed.txt"
    assert cli.main(["clips", "import", str(source), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "mapping guessed from the joint names" in printed and "chest mixamorig:Spine1" in printed
    assert cli.main(["clips", "import", str(source), "--out", str(out), "--json"]) == 0
    mapping_file = tmp_path / "mapping.json"
    mapping_file.write_text(json.dumps(json.loads(capsys.readouterr().out)["mapping_file"]))
    again = tmp_path / "again.txt"
    assert cli.main(["clips", "import", str(source), "--out", str(again), "--mapping", str(mapping_file)]) == 0
    def frames(path):  # all but the comment
        return [line for line in path.read_text().splitlines() if not line.startswith('"Comment"')]

    assert frames(again) == frames(out)


@pytest.mark.parametrize("args, message", [
    (["--start", "1.5", "--end", "1.0"], "--start 1.5 --end 1 s is not within its 2.000 s"),
    (["--end", "9"], "is not within its 2.000 s"),
    (["--fps", "0"], "--fps 0: must be positive"),
    (["--mapping", "nowhere.json"], "nowhere.json: cannot read the mapping file"),
])
def test_import_command_errors(walk_file, tmp_path, capsys, args, message):
    out = tmp_path / "walk.txt"
    assert cli.main(["clips", "import", str(walk_file), "--out", str(out), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
    assert not out.exists() and not list(tmp_path.glob("*.tmp"))


@pytest.mark.parametrize("command", [["import", "BVH"], ["retarget", "slow_walk", "--to", "humanoid"]])
def test_clip_out_is_checked_before_the_work(walk_file, tmp_path, capsys, command):
    """--out naming a folder, or a file in none: one line before anything is read or written (a
    folder gave a traceback and left FOLDER.tmp beside it)."""
    args = [str(walk_file) if a == "BVH" else a for a in command]
    folder = tmp_path / "clips"
    folder.mkdir()
    for out, message in ((folder, "is a folder; give the clip file's name"), (tmp_path / "no" / "c.txt", "no folder")):
        assert cli.main(["clips", *args, "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert message in err and "\n" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clips"] and not list(folder.iterdir())


def test_real_cmu_recordings(tmp_path):
    """The CMU files in ../shared/bvh (skipped without them): both import onto the humanoid."""
    from conftest import REPO

    folder = REPO.parent / "shared" / "bvh" / "cmu"
    if not folder.is_dir():
        pytest.skip("../shared/bvh/cmu is not present")
    character = load_character()
    for path in sorted(folder.glob("*.bvh")):
        bvh = load_bvh(path)
        result = import_bvh(bvh, character, find_mapping(bvh, "humanoid"))
        assert result.report["mapping"].endswith("cmu_max.json")
        assert result.report["end_effector_error_m"]["left_ankle"] < 0.03
        assert result.report["penetration_max_m"] < 0.02
        assert np.all(np.isfinite(result.clip.qpos))
        q = result.clip.qpos[:, 3:7]
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-9)
        assert quat.angle(q[0]) >= 0
