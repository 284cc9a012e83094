"""Clip loading, validation, name resolution, and the project's authored clips."""

from __future__ import annotations

import importlib.util
import json
import math
import os
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjxmimic.motion import clip as clip_mod
from mjxmimic.motion.clip import (
    PROJECT_CLIPS,
    Clip,
    ClipError,
    format_clip,
    list_clips,
    load_clip,
    load_clip_source,
    lowest_points,
    resolve_clip,
)

HUMANOID = ["backflip", "cartwheel", "crawl", "dance_a", "dance_b", "getup_facedown", "getup_faceup", "jump",
            "kick", "punch", "roll", "run", "spin", "spinkick", "walk"]
WALKER = ["0walk_forward", "turn_left0", "turn_left1", "turn_right0", "turn_right1"]
# DEEPMIMIC.md, "Motion clip format": clip lengths in seconds, and the clips that do not loop.
LENGTHS = {"backflip": 1.75, "cartwheel": 2.72, "crawl": 2.93, "dance_a": 1.62, "dance_b": 2.53,
           "getup_facedown": 3.03, "getup_faceup": 3.77, "jump": 1.77, "kick": 1.53, "punch": 2.13,
           "roll": 2.02, "run": 0.80, "spin": 4.42, "spinkick": 1.28, "walk": 1.27}
NO_LOOP = {"getup_facedown", "getup_faceup", "kick", "punch"}
AUTHORED = ["slow_walk", "squat", "wave"]  # looping; the project's pitch does not (tests/test_throw.py)
PROJECT = AUTHORED + ["pitch"]


def quat_adrs(character) -> list[int]:
    return [3] + [j.qpos_adr for j in character.joints if j.kind == "ball"]


def joint(character, name):
    return next(j for j in character.joints if j.name == name)


# --------------------------------------------------------------------------- the DeepMimic clips


@pytest.mark.parametrize("name", HUMANOID)
def test_humanoid_clip_loads(deepmimic_dir, character, name):
    path = deepmimic_dir / "motions" / f"humanoid3d_{name}.txt"
    clip = load_clip(path, character)
    raw = json.loads(path.read_text())
    assert clip.name == name
    assert clip.path == path
    assert clip.qpos.shape == (len(raw["Frames"]), character.nq)
    assert clip.durations.shape == (len(raw["Frames"]),)
    assert np.all(np.isfinite(clip.qpos))
    for adr in quat_adrs(character):
        q = clip.qpos[:, adr:adr + 4]
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
        assert np.all(np.einsum("fi,fi->f", q[1:], q[:-1]) >= 0), "quaternions not hemisphere-consistent"
    assert clip.duration == pytest.approx(LENGTHS[name], abs=0.01)
    assert clip.loop == (name not in NO_LOOP)
    assert clip.loop_mode == ("none" if name in NO_LOOP else "wrap")


@pytest.mark.parametrize("name", WALKER)
def test_walker_clip_loads(deepmimic_dir, character, name):
    clip = load_clip(deepmimic_dir / "motions" / "walker" / f"{name}.txt", character)
    assert clip.loop
    assert clip.num_frames == 38
    assert clip.duration == pytest.approx(37 / 30, abs=1e-6)
    assert clip.fps == pytest.approx(30.0, abs=1e-6)
    for adr in quat_adrs(character):
        np.testing.assert_allclose(np.linalg.norm(clip.qpos[:, adr:adr + 4], axis=1), 1.0, atol=1e-12)


def test_walk_conversion_matches_the_file(deepmimic_dir, character):
    """y-up -> z-up: (x, y, z) -> (x, -z, y) for positions and quaternion vector parts."""
    path = deepmimic_dir / "motions" / "humanoid3d_walk.txt"
    clip = load_clip(path, character)
    frames = np.asarray(json.loads(path.read_text())["Frames"])
    # Root height: the file's y, about 0.85 m.
    assert clip.qpos[0, 2] == pytest.approx(frames[0, 2]) == pytest.approx(0.8475, abs=1e-3)
    # Sideways: z-up y is minus the file's z (pick a frame where z is clearly non-zero).
    f = int(np.argmax(np.abs(frames[:, 3])))
    assert abs(frames[f, 3]) > 1e-3
    np.testing.assert_allclose(clip.qpos[f, 0:3], [frames[f, 1], -frames[f, 3], frames[f, 2]], atol=1e-12)
    # Root quaternion and the right hip (2nd ball joint after chest, neck): (w, x, y, z) -> (w, x, -z, y).
    def conv(q):
        q = np.array([q[0], q[1], -q[3], q[2]])
        return q / np.linalg.norm(q)

    np.testing.assert_allclose(clip.qpos[f, 3:7], conv(frames[f, 4:8]), atol=1e-12)
    hip = joint(character, "right_hip")
    np.testing.assert_allclose(clip.qpos[f, hip.qpos_adr:hip.qpos_adr + 4], conv(frames[f, 16:20]),
                               atol=1e-12)
    # Hinges are copied: right knee is number 20 of the frame, left elbow the last.
    assert clip.qpos[f, joint(character, "right_knee").qpos_adr] == frames[f, 20]
    assert clip.qpos[f, joint(character, "left_elbow").qpos_adr] == frames[f, 43]


def test_walk_pose_stands_on_the_floor(deepmimic_dir, character):
    """A wrong axis map would sink the feet or tip the body: soles touch z = 0, head above root."""
    clip = load_clip(deepmimic_dir / "motions" / "humanoid3d_walk.txt", character)
    soles = lowest_points(character, clip.qpos, character.body_sets["feet"])
    assert soles.min() > -0.02 and soles.max() < 0.03
    assert np.all(lowest_points(character, clip.qpos) > -0.02)
    data = mujoco.MjData(character.model)
    neck = mujoco.mj_name2id(character.model, mujoco.mjtObj.mjOBJ_BODY, "neck")
    for q in clip.qpos[::5]:
        data.qpos[:] = q
        mujoco.mj_kinematics(character.model, data)
        assert data.xpos[neck, 2] - q[2] > 0.4
    assert clip.mean_speed == pytest.approx(0.98, abs=0.03)
    assert abs(clip.root_displacement[0]) > 1.0  # walks along +x


def test_run_speed(deepmimic_dir, character):
    clip = load_clip(deepmimic_dir / "motions" / "humanoid3d_run.txt", character)
    assert clip.mean_speed == pytest.approx(3.56, abs=0.05)


def test_kick_quaternions_are_normalised(deepmimic_dir, character):
    path = deepmimic_dir / "motions" / "humanoid3d_kick.txt"
    clip = load_clip(path, character)
    assert clip.max_quat_norm_error == pytest.approx(0.42, abs=0.01)
    for adr in quat_adrs(character):
        np.testing.assert_allclose(np.linalg.norm(clip.qpos[:, adr:adr + 4], axis=1), 1.0, atol=1e-12)


# ------------------------------------------------------------------------------- small clip files


def frame(character, duration=1 / 30, root=(0.0, 0.9, 0.0)) -> list[float]:
    """A valid frame: identity rotations, hinges at their limit-safe values."""
    values = [duration, *root, 1.0, 0.0, 0.0, 0.0]
    for j in character.joints:
        values += [1.0, 0.0, 0.0, 0.0] if j.kind == "ball" else [0.0]
    return values


def write(tmp_path: Path, content, name="clip.txt") -> Path:
    path = tmp_path / name
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    return path


def good(character, n=3) -> dict:
    return {"Loop": "wrap", "Frames": [frame(character) for _ in range(n)]}


def test_small_clip_properties(tmp_path, character):
    frames = [frame(character, 0.1, (0, 0.9, 0)), frame(character, 0.2, (1, 0.9, -2)),
              frame(character, 0.0, (3, 0.95, -4))]  # the last duration is ignored, may be 0
    clip = load_clip(write(tmp_path, {"Loop": "none", "Frames": frames}), character)
    assert isinstance(clip, Clip)
    assert not clip.loop
    np.testing.assert_allclose(clip.frame_times, [0.0, 0.1, 0.3])
    assert clip.duration == pytest.approx(0.3)
    assert clip.fps == pytest.approx(2 / 0.3)
    assert clip.num_frames == 3
    np.testing.assert_allclose(clip.root_pos[-1], [3, 4, 0.95])  # y-up (3, .95, -4) -> z-up (3, 4, .95)
    assert clip.root_travel == pytest.approx(5.0)
    assert clip.mean_speed == pytest.approx(5.0 / 0.3)
    assert not clip.qpos.flags.writeable


def test_hemisphere_flip(tmp_path, character):
    frames = [frame(character) for _ in range(3)]
    h = 16  # right hip: after duration, root position and quaternion, chest, neck (1 + 3 + 4 + 4 + 4)
    frames[0][h:h + 4] = [0.8, 0.6, 0.0, 0.0]
    frames[1][h:h + 4] = [-0.8, -0.6, 0.0, 0.0]  # the same rotation, other hemisphere
    frames[2][h:h + 4] = [-0.6, -0.8, 0.0, 0.0]
    frames[1][4:8] = [-1.0, 0.0, 0.0, 0.0]  # root too
    clip = load_clip(write(tmp_path, {"Loop": "wrap", "Frames": frames}), character)
    adr = joint(character, "right_hip").qpos_adr
    np.testing.assert_allclose(clip.qpos[:, adr:adr + 4],
                               [[0.8, 0.6, 0, 0], [0.8, 0.6, 0, 0], [0.6, 0.8, 0, 0]])
    np.testing.assert_allclose(clip.qpos[:, 3:7], [[1, 0, 0, 0]] * 3)


def test_format_round_trip(deepmimic_dir, character, tmp_path):
    clip = load_clip(deepmimic_dir / "motions" / "humanoid3d_cartwheel.txt", character)
    again = load_clip(write(tmp_path, format_clip(clip, character)), character)
    assert again.loop == clip.loop
    np.testing.assert_allclose(again.durations, clip.durations, atol=1e-10)
    np.testing.assert_allclose(again.qpos, clip.qpos, atol=1e-9)


def _bad_cases(character):
    w = character.clip_width
    ok = frame(character)
    return {
        "not_json": ("{\"Loop\": \"wrap\",\n \"Frames\": [oops]}", ["not JSON", "line 2"]),
        "empty": ("", ["not JSON", "line 1"]),
        "top_list": ([ok, ok], ["top level", "object"]),
        "no_loop": ({"Frames": [ok, ok]}, ["missing \"Loop\""]),
        "no_frames": ({"Loop": "wrap"}, ["missing \"Frames\""]),
        "bad_loop": ({"Loop": "clamp", "Frames": [ok, ok]}, ["Loop", "'clamp'", "wrap", "none"]),
        "frames_object": ({"Loop": "wrap", "Frames": {"0": ok}}, ["\"Frames\" must be a list"]),
        "one_frame": ({"Loop": "wrap", "Frames": [ok]}, ["at least two frames", "got 1"]),
        "frame_not_list": ({"Loop": "wrap", "Frames": [ok, 5, ok]}, ["frame 1 (0-based)", "list of numbers"]),
        "string_value": ({"Loop": "wrap", "Frames": [ok, ok, ok[:5] + ["x"] + ok[6:]]},
                         ["frame 2 (0-based)", "value 5", "not a number"]),
        "bool_value": ({"Loop": "wrap", "Frames": [[True] + ok[1:], ok]},
                       ["frame 0 (0-based)", "not a number"]),
        "null_value": ({"Loop": "wrap", "Frames": [ok, ok[:-1] + [None]]},
                       ["frame 1 (0-based)", "not a number"]),
        "short_frame": ({"Loop": "wrap", "Frames": [ok, ok, ok[:-1]]},
                        ["frame 2 (0-based)", f"expected {w}", f"got {w - 1}"]),
        "long_frame": ({"Loop": "wrap", "Frames": [ok + [0.0], ok]}, ["frame 0 (0-based)", f"got {w + 1}"]),
        "zero_duration": ({"Loop": "wrap", "Frames": [ok, [0.0] + ok[1:], ok]},
                          ["frame 1 (0-based)", "duration must be positive"]),
        "negative_duration": ({"Loop": "none", "Frames": [[-0.1] + ok[1:], ok]},
                              ["frame 0 (0-based)", "duration must be positive"]),
        "zero_quat": ({"Loop": "wrap", "Frames": [ok, ok[:16] + [0.0] * 4 + ok[20:]]},
                      ["frame 1 (0-based)", "right_hip", "zero norm"]),
        "zero_root_quat": ({"Loop": "wrap", "Frames": [ok[:4] + [0.0] * 4 + ok[8:], ok]},
                           ["frame 0 (0-based)", "root", "zero norm"]),
    }


BAD = ["not_json", "empty", "top_list", "no_loop", "no_frames", "bad_loop", "frames_object", "one_frame",
       "frame_not_list", "string_value", "bool_value", "null_value", "short_frame", "long_frame",
       "zero_duration", "negative_duration", "zero_quat", "zero_root_quat"]


@pytest.mark.parametrize("case", BAD)
def test_bad_clip_raises_clip_error(tmp_path, character, case):
    content, expected = _bad_cases(character)[case]
    path = write(tmp_path, content, f"{case}.txt")
    with pytest.raises(ClipError) as info:
        load_clip(path, character)
    message = str(info.value)
    assert str(path) in message
    for part in expected:
        assert part in message, f"{part!r} not in {message!r}"
    assert "\n" not in message
    if "frame" not in " ".join(expected):
        assert "0-based" not in message


@pytest.mark.parametrize("literal, frame_index",
                         [("NaN", 1), ("Infinity", 2), ("-Infinity", 0), ("1e999", 1)])
def test_non_finite_values(tmp_path, character, literal, frame_index):
    frames = [json.dumps(frame(character)) for _ in range(3)]
    values = frame(character)
    frames[frame_index] = "[" + ", ".join([json.dumps(v) for v in values[:9]] + [literal]
                                          + [json.dumps(v) for v in values[10:]]) + "]"
    path = write(tmp_path, "{\"Loop\": \"wrap\", \"Frames\": [" + ",\n".join(frames) + "]}")
    with pytest.raises(ClipError) as info:
        load_clip(path, character)
    message = str(info.value)
    assert str(path) in message and f"frame {frame_index} (0-based)" in message and "value 9" in message
    assert "NaN or infinite" in message


def test_missing_and_directory(tmp_path, character):
    with pytest.raises(ClipError, match="not found") as info:
        load_clip(tmp_path / "nope.txt", character)
    assert str(tmp_path / "nope.txt") in str(info.value)
    with pytest.raises(ClipError, match="not a file"):
        load_clip(tmp_path, character)


def test_clip_error_is_a_user_error():
    from mjxmimic.core.errors import UserError

    assert issubclass(ClipError, UserError)


# ------------------------------------------------------------------------------- name resolution


@pytest.fixture
def no_user_dirs(monkeypatch):
    """No MJXMIMIC_CLIPS, no pybullet: only the project's clips/ unless a test adds more."""
    monkeypatch.delenv("MJXMIMIC_CLIPS", raising=False)
    monkeypatch.setattr(clip_mod, "_pybullet_motions_dir", lambda: None)
    return monkeypatch


def test_existing_path_always_works(tmp_path, character, no_user_dirs):
    path = write(tmp_path, good(character), "slow_walk.txt")  # same name as a project clip
    assert resolve_clip(str(path)) == path
    assert resolve_clip(path) == path


def test_project_clips_come_first(tmp_path, character, no_user_dirs):
    write(tmp_path, good(character), "slow_walk.txt")
    assert resolve_clip("slow_walk", tmp_path) == PROJECT_CLIPS / "slow_walk.txt"
    no_user_dirs.setenv("MJXMIMIC_CLIPS", str(tmp_path))
    assert resolve_clip("slow_walk") == PROJECT_CLIPS / "slow_walk.txt"


def test_env_folders_in_order(deepmimic_dir, tmp_path, character, no_user_dirs):
    motions = deepmimic_dir / "motions"
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir()
    second.mkdir()
    no_user_dirs.setenv("MJXMIMIC_CLIPS", os.pathsep.join([str(first), str(motions)]))
    assert resolve_clip("walk") == motions / "humanoid3d_walk.txt"  # "walk" -> humanoid3d_walk.txt
    write(first, good(character), "walk.txt")
    assert resolve_clip("walk") == first / "walk.txt"  # the earlier folder wins
    write(second, good(character), "walk.json")
    assert resolve_clip("walk", second) == second / "walk.json"  # the argument replaces the variable
    assert resolve_clip("walker/turn_left0", None) == motions / "walker" / "turn_left0.txt"


def test_name_forms_in_one_folder(tmp_path, character, no_user_dirs):
    write(tmp_path, good(character), "humanoid3d_hop.txt")
    assert resolve_clip("hop", tmp_path) == tmp_path / "humanoid3d_hop.txt"
    write(tmp_path, good(character), "hop.json")
    assert resolve_clip("hop", tmp_path) == tmp_path / "hop.json"
    write(tmp_path, good(character), "hop.txt")
    assert resolve_clip("hop", tmp_path) == tmp_path / "hop.txt"
    assert resolve_clip("hop.json", tmp_path) == tmp_path / "hop.json"


def test_pybullet_after_user_folders(tmp_path, character, monkeypatch):
    pybullet, user = tmp_path / "pybullet_motions", tmp_path / "user"
    pybullet.mkdir()
    user.mkdir()
    write(pybullet, good(character), "humanoid3d_hop.txt")
    monkeypatch.setattr(clip_mod, "_pybullet_motions_dir", lambda: pybullet)
    monkeypatch.delenv("MJXMIMIC_CLIPS", raising=False)
    assert resolve_clip("hop") == pybullet / "humanoid3d_hop.txt"
    write(user, good(character), "hop.txt")
    monkeypatch.setenv("MJXMIMIC_CLIPS", str(user))
    assert resolve_clip("hop") == user / "hop.txt"
    assert [label for label, _ in clip_mod.search_folders()] == ["project", "MJXMIMIC_CLIPS", "pybullet"]


def test_pybullet_folder_is_found_without_import(monkeypatch, tmp_path):
    package = tmp_path / "pybullet_data"
    package.mkdir()
    (package / "__init__.py").write_text("raise RuntimeError('must not be imported')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert clip_mod._pybullet_motions_dir() == package / "data" / "motions"


def test_unknown_name_lists_where_it_looked(tmp_path, no_user_dirs):
    with pytest.raises(ClipError) as info:
        resolve_clip("no_such_clip", tmp_path)
    message = str(info.value)
    assert "no_such_clip" in message
    assert str(PROJECT_CLIPS) in message and str(tmp_path) in message
    assert "humanoid3d_no_such_clip.txt" in message


def test_list_clips(deepmimic_dir, tmp_path, character, no_user_dirs):
    write(tmp_path, good(character), "walk.txt")
    write(tmp_path, good(character), "slow_walk.txt")
    no_user_dirs.setenv("MJXMIMIC_CLIPS", os.pathsep.join([str(tmp_path), str(deepmimic_dir / "motions")]))
    found = {name: (path, label) for name, path, label in list_clips()}
    for name in PROJECT:
        assert found[name] == (PROJECT_CLIPS / f"{name}.txt", "project")
    assert found["walk"] == (tmp_path / "walk.txt", "MJXMIMIC_CLIPS")  # first source wins
    assert found["backflip"] == (deepmimic_dir / "motions" / "humanoid3d_backflip.txt", "MJXMIMIC_CLIPS")
    assert not any(name.startswith("humanoid3d_") for name in found)
    assert "make_clips" not in found
    names = [name for name, _, _ in list_clips()]
    assert names == sorted(names) and len(names) == len(set(names))
    assert {name for name, _, _ in list_clips(tmp_path)} == set(PROJECT) | {"walk"}


def test_load_clip_source(deepmimic_dir, character, no_user_dirs):
    clip = load_clip_source("run", character, deepmimic_dir / "motions")
    assert clip.name == "run" and clip.num_frames == 25


# ------------------------------------------------------------------------------- authored clips


def sole_heights(character, qpos: np.ndarray, corner: int = 0) -> np.ndarray:
    """(F, 2) lowest corner of each foot box (corner=3: the highest of its four lowest corners,
    which is on the floor only when the sole is flat), straight from mujoco kinematics."""
    model, data = character.model, mujoco.MjData(character.model)
    feet = character.body_sets["feet"]
    boxes = [g for g in range(model.ngeom) if model.geom_bodyid[g] in feet and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
    assert len(boxes) == 2 and all(model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX for g in boxes)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    out = np.empty((len(qpos), 2))
    for f, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for i, g in enumerate(boxes):
            corners = data.geom_xpos[g] + (signs * model.geom_size[g]) @ data.geom_xmat[g].reshape(3, 3).T
            out[f, i] = np.sort(corners[:, 2])[corner]
    return out


@pytest.fixture(scope="module")
def authored(character):
    return {name: load_clip(PROJECT_CLIPS / f"{name}.txt", character) for name in AUTHORED}


@pytest.mark.parametrize("name", AUTHORED)
def test_authored_clip_is_physical(authored, character, name):
    clip = authored[name]
    assert clip.loop and clip.fps == pytest.approx(30.0, abs=1e-6)
    soles = sole_heights(character, clip.qpos)
    per_frame = soles.min(axis=1)
    assert np.all(np.abs(per_frame) < 0.01), "a frame without a foot on the floor"
    assert abs(per_frame.min()) < 0.02
    np.testing.assert_allclose(lowest_points(character, clip.qpos, character.body_sets["feet"]), per_frame,
                               atol=1e-12)
    assert np.all(lowest_points(character, clip.qpos) > -0.01), "some body part below the floor"
    # The cycle joins: the last frame is the first, moved by the travel in the ground plane only.
    np.testing.assert_allclose(clip.qpos[-1, 2:], clip.qpos[0, 2:], atol=1e-9)
    np.testing.assert_allclose(clip.root_displacement[2], 0.0, atol=1e-9)
    # Hinges inside their ranges.
    model = character.model
    for j in character.joints:
        if j.kind == "hinge":
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            lo, hi = model.jnt_range[jid]
            assert np.all((clip.qpos[:, j.qpos_adr] >= lo) & (clip.qpos[:, j.qpos_adr] <= hi)), j.name


def test_slow_walk(authored, character):
    clip = authored["slow_walk"]
    assert 1.2 <= clip.duration <= 1.6
    assert 0.5 <= clip.mean_speed <= 0.8
    assert clip.root_displacement[0] > 0.6 and abs(clip.root_displacement[1]) < 1e-6
    assert abs(clip.heading_change) < 1e-6
    assert clip.max_quat_norm_error < 1e-8
    # Knees flex in swing (more than 45 deg), and both legs alternate.
    for side in ("right", "left"):
        assert clip.qpos[:, joint(character, f"{side}_knee").qpos_adr].min() < -0.8
    # Legs swing and arms counter-swing: wrist and ankle positions relative to the root, along x.
    model, data = character.model, mujoco.MjData(character.model)
    ids = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n)
           for n in ("right_ankle", "left_ankle", "right_wrist", "left_wrist")}
    rel = {n: [] for n in ids}
    for q in clip.qpos:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for n, b in ids.items():
            rel[n].append(data.xpos[b, 0] - q[0])
    rel = {n: np.array(v) for n, v in rel.items()}
    assert np.ptp(rel["right_ankle"]) > 0.35
    assert np.ptp(rel["right_wrist"]) > 0.1
    assert np.corrcoef(rel["right_ankle"], rel["right_wrist"])[0, 1] < -0.5
    assert np.corrcoef(rel["right_ankle"], rel["left_ankle"])[0, 1] < -0.5
    # A planted foot does not slide while its sole is flat on the floor.
    flat = sole_heights(character, clip.qpos, corner=3) < 1e-3
    for i, name in enumerate(("right_ankle", "left_ankle")):
        frames = np.flatnonzero(flat[:, i])
        assert 8 <= len(frames) < clip.num_frames // 2 + 2
        assert np.all(np.diff(frames) == 1), "one flat stance phase per cycle"
        world_x = rel[name][frames] + clip.qpos[frames, 0]
        assert np.ptp(world_x) < 0.002


def test_squat(authored, character):
    clip = authored["squat"]
    assert clip.duration == pytest.approx(2.0, abs=1e-6)
    assert clip.root_travel < 1e-9
    height = clip.root_pos[:, 2]
    assert height[0] == pytest.approx(height.max()) and height.max() - height.min() > 0.3
    assert np.argmin(height) == pytest.approx(clip.num_frames // 2, abs=2)
    knee = clip.qpos[:, joint(character, "right_knee").qpos_adr]
    assert knee.min() < -1.5 and knee[0] > -0.1


def test_script_reproduces_committed_clips(character):
    spec = importlib.util.spec_from_file_location("make_clips", PROJECT_CLIPS / "make_clips.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    texts = module.clip_texts(character)
    assert {f"{n}.txt" for n in PROJECT} <= set(texts)
    assert set(texts) == {p.name for p in PROJECT_CLIPS.glob("*.txt")}
    for fname, text in texts.items():
        assert (PROJECT_CLIPS / fname).read_text() == text, f"clips/{fname} differs from make_clips.py"


def test_default_clip_resolves(character, no_user_dirs):
    from mjxmimic.core.config import ClipConfig

    assert resolve_clip(ClipConfig().name) == PROJECT_CLIPS / "slow_walk.txt"
    assert math.isclose(load_clip_source("slow_walk", character).mean_speed, 0.65, abs_tol=0.01)
