"""Headless videos: `mjxmimic render` (policy + ghost) and `mjxmimic clips render` write mp4 files
whose frames change; the ghost is drawn. Skipped, with the reason, where imageio/imageio-ffmpeg
(the "render" extra) or a headless OpenGL (EGL or OSMesa) is missing."""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError

REPO = Path(__file__).resolve().parent.parent

imageio = pytest.importorskip("imageio.v2", reason="the render extra (imageio) is not installed")
pytest.importorskip("imageio_ffmpeg", reason="the render extra (imageio-ffmpeg) is not installed")


@pytest.fixture(scope="module", autouse=True)
def gl():
    from mjxmimic.portable.render import setup_gl

    try:
        return setup_gl()
    except UserError as err:
        pytest.skip(f"no headless OpenGL: {err}")


@pytest.fixture(scope="module")
def policy_file(tmp_path_factory, character):
    """An exported policy of random weights (numpy only: no training, no JAX)."""
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.portable.policy_file import make_policy_file, write_npz

    rng = np.random.default_rng(0)
    sizes = [227, 32, 32, 56]
    policy = {f"hidden_{i}": {"kernel": rng.normal(scale=1 / np.sqrt(a), size=(a, b)).astype(np.float32),
                              "bias": np.zeros(b, np.float32)} for i, (a, b) in enumerate(itertools.pairwise(sizes))}
    params = {"normalizer": {"mean": np.zeros(227, np.float32), "std": np.ones(227, np.float32)}, "policy": policy}
    config = config_lib.make_config("cpu", {"env.action_mode": "residual", "env.action_scale": 0.2})
    pf = make_policy_file(config, character, load_clip_source("slow_walk", character), params)
    return write_npz(pf, tmp_path_factory.mktemp("policy") / "policy.npz")


def run_cli(*args) -> subprocess.CompletedProcess:
    code = ("import sys; from mjxmimic.cli import main; rc = main(sys.argv[1:]); "
            "print('JAX_IMPORTED=' + str('jax' in sys.modules), file=sys.stderr); sys.exit(rc)")
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}  # render.py chooses
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=180, check=False)


def read_frames(path: Path) -> list[np.ndarray]:
    with imageio.get_reader(str(path)) as reader:
        return [np.asarray(f) for f in reader]


def test_render_policy_with_ghost_writes_a_changing_video(policy_file, tmp_path):
    out = tmp_path / "policy.mp4"
    result = run_cli("render", policy_file, "--out", out, "--ghost", "--seconds", "1", "--width", "160",
                     "--height", "128")
    assert result.returncode == 0, result.stderr
    assert "JAX_IMPORTED=False" in result.stderr
    assert out.is_file() and not list(tmp_path.glob("*.part*"))
    frames = read_frames(out)
    assert len(frames) >= 5 and frames[0].shape == (128, 160, 3)
    diffs = [np.abs(f.astype(int) - frames[0].astype(int)).mean() for f in frames[1:]]
    assert max(diffs) > 1.0, diffs  # the character moves


def test_clips_render_writes_a_changing_video(tmp_path):
    out = tmp_path / "squat.mp4"
    result = run_cli("clips", "render", "squat", "--out", out, "--seconds", "1.5", "--width", "160",
                     "--height", "128")
    assert result.returncode == 0, result.stderr
    frames = read_frames(out)
    assert len(frames) == 46  # 1.5 s at 30 fps, both ends
    assert np.abs(frames[-1].astype(int) - frames[0].astype(int)).mean() > 0.5 or \
        np.abs(frames[len(frames) // 2].astype(int) - frames[0].astype(int)).mean() > 0.5


def test_ghost_is_drawn_translucent(character):
    from mjxmimic.motion import library as motion
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.portable.render import GHOST_PREFIX, Scene

    lib = motion.build_motion_lib([load_clip_source("slow_walk", character)], character)
    qpos, _ = motion.sample(lib, 0, 0.3)
    plain = Scene(character.xml_path, character.nq, ghost=False, width=160, height=128)
    ghosted = Scene(character.xml_path, character.nq, ghost=True, width=160, height=128)
    try:
        assert ghosted.model.nq == 2 * character.nq and plain.model.nq == character.nq
        names = [ghosted.model.geom(i).name for i in range(ghosted.model.ngeom)]
        ghost_geoms = [i for i, n in enumerate(names) if n.startswith(GHOST_PREFIX)]
        assert len(ghost_geoms) == character.model.ngeom - 1  # every body geom, not the floor
        assert np.all(ghosted.model.geom_rgba[ghost_geoms, 3] < 0.5)
        assert np.all(ghosted.model.geom_contype[ghost_geoms] == 0)
        assert np.all(ghosted.model.geom_conaffinity[ghost_geoms] == 0)
        shifted = np.array(qpos, np.float64)
        shifted[0] += 0.6  # the ghost a little ahead (the camera looks from the side)
        a = plain.frame(qpos)
        b = ghosted.frame(qpos, shifted)
        assert a.shape == b.shape == (128, 160, 3)
        assert np.abs(a.astype(int) - b.astype(int)).mean() > 0.3
    finally:
        plain.close()
        ghosted.close()


def test_bad_output_name_and_size_are_one_line_errors(policy_file, tmp_path):
    result = run_cli("render", policy_file, "--out", tmp_path / "x.gif")
    assert result.returncode == 2 and "expected a video file name ending in .mp4" in result.stderr
    result = run_cli("clips", "render", "squat", "--width", "100", "--out", tmp_path / "y.mp4")
    assert result.returncode == 2 and "multiple of 16" in result.stderr
    assert not (tmp_path / "x.gif").exists() and not (tmp_path / "y.mp4").exists()


def test_push_is_drawn_as_a_red_arrow(character):
    from mjxmimic.motion import library as motion
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.portable.render import PUSH_RGBA, Scene

    lib = motion.build_motion_lib([load_clip_source("slow_walk", character)], character)
    qpos, _ = motion.sample(lib, 0, 0.3)
    scene = Scene(character.xml_path, character.nq, ghost=False, width=160, height=128)
    try:
        root = np.array([qpos[0], qpos[1], qpos[2]])
        plain = scene.frame(qpos).astype(int)
        pushed = scene.frame(qpos, arrows=[(root - [0.0, 0.8, 0.0], root, PUSH_RGBA)]).astype(int)
    finally:
        scene.close()
    changed = np.abs(pushed - plain).sum(axis=-1) > 30
    assert changed.sum() > 50  # the arrow is there
    red = pushed[changed]
    assert np.mean(red[:, 0] > red[:, 1] + 40) > 0.5  # and red


def test_render_push_knocks_down_and_bad_push_is_one_line(policy_file, tmp_path):
    frames = {}
    for name, push in (("still", []), ("pushed", ["--push", "4000@0.2", "--push-direction", "sideways"])):
        out = tmp_path / f"{name}.mp4"
        result = run_cli("render", policy_file, "--out", out, *push, "--seconds", "2", "--width", "160",
                         "--height", "128")
        assert result.returncode == 0, result.stderr
        assert "JAX_IMPORTED=False" in result.stderr
        frames[name] = len(read_frames(out))
    assert ", fell," in result.stdout and frames["pushed"] < frames["still"] - 5  # knocked down sooner
    result = run_cli("render", policy_file, "--out", tmp_path / "bad.mp4", "--push", "300N")
    assert result.returncode == 2 and "expected FORCE@TIME" in result.stderr
    late = run_cli("render", policy_file, "--out", tmp_path / "bad.mp4", "--push", "300@5", "--seconds", "2")
    assert late.returncode == 2 and "--push at 5 s: the video ends at 2 s" in late.stderr
    assert not (tmp_path / "bad.mp4").exists()


def test_png_out_writes_a_frame_strip(policy_file, tmp_path):
    out = tmp_path / "strip.png"
    result = run_cli("render", policy_file, "--out", out, "--seconds", "1", "--width", "160", "--height", "128")
    assert result.returncode == 0, result.stderr
    strip = imageio.imread(str(out))
    assert strip.shape[0] == 128 and strip.shape[1] == 8 * 160  # 8 frames side by side
    first, last = strip[:, :160].astype(int), strip[:, -160:].astype(int)
    assert np.abs(first - last).mean() > 0.5  # different moments


def test_a_gl_backend_without_its_library_is_one_line(policy_file, tmp_path):
    from mjxmimic.portable.render import _osmesa_available

    if _osmesa_available():
        pytest.skip("OSMesa is installed here")
    code = "import sys; from mjxmimic.cli import main; sys.exit(main(sys.argv[1:]))"
    env = dict(os.environ, MUJOCO_GL="osmesa")
    result = subprocess.run([sys.executable, "-c", code, "render", str(policy_file), "--out", str(tmp_path / "v.mp4")],
                            cwd=REPO, env=env, capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [result.stderr.strip()] and "no OSMESA library" in result.stderr


def test_render_stops_at_the_end_of_a_clip_that_does_not_loop(policy_file, character, tmp_path):
    """The episode ends with the clip (done, not a fall): the video stops there and says so."""
    import dataclasses

    from mjxmimic.motion.clip import format_clip, load_clip_source

    walk = load_clip_source("slow_walk", character)
    once = dataclasses.replace(walk, loop=False, qpos=walk.qpos[:16], durations=walk.durations[:16])
    clip_file = tmp_path / "once.txt"
    clip_file.write_text(format_clip(once, character))
    out = tmp_path / "once.mp4"
    result = run_cli("render", policy_file, "--clip", clip_file, "--out", out, "--seconds", "4", "--width", "160",
                     "--height", "128", "--no-ghost")
    assert result.returncode == 0, result.stderr
    assert "did not fall" in result.stdout
    assert len(read_frames(out)) < 4 * 30 / 2


def test_character_given_to_a_policy_command_must_be_the_files(policy_file, tmp_path, capsys):
    """--character on play, render, eval and export: the file holds the character; another one is
    refused in one line, the same one passes."""
    from mjxmimic import cli
    from mjxmimic.commands.character_option import check as check_character

    check_character("humanoid", policy_file)
    check_character(None, policy_file)
    for command in (["play", str(policy_file), "--episodes", "1"], ["render", str(policy_file), "--out",
                    str(tmp_path / "v.mp4")], ["eval", str(policy_file)]):
        assert cli.main([*command, "--character", "dog3d"]) == 2
        err = capsys.readouterr().err.strip()
        assert err.endswith("moves humanoid, not dog3d (it holds its character; drop --character)"), err
        assert len(err.splitlines()) == 1
    assert not (tmp_path / "v.mp4").exists()


def test_a_push_must_be_finite_and_names_its_flag():
    from mjxmimic.commands.render import parse_push

    assert parse_push("300@1.5", "forward") == (300.0, 1.5, 0.0)
    for text in ("inf@1", "300@nan", "-5@1"):
        with pytest.raises(UserError, match=f"--push-once '{text}': force and time must be finite and >= 0"):
            parse_push(text, "forward", "--push-once")
