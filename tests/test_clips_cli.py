"""`mjxmimic clips list|info` end to end."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mjxmimic import cli
from mjxmimic.motion.clip import PROJECT_CLIPS
from mjxmimic.commands import clips as clips_cmd

REPO = Path(__file__).resolve().parent.parent


def run_cli(*args: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "MJXMIMIC_CLIPS"}
    return subprocess.run([sys.executable, "-m", "mjxmimic.cli", *args], cwd=REPO, env=env, check=False,
                          capture_output=True, text=True, timeout=120)


@pytest.fixture(autouse=True)
def no_env(monkeypatch):
    monkeypatch.delenv("MJXMIMIC_CLIPS", raising=False)


def test_info_on_a_shared_clip(deepmimic_dir):
    result = run_cli("clips", "info", str(deepmimic_dir / "motions" / "humanoid3d_walk.txt"))
    assert result.returncode == 0, result.stderr
    out = result.stdout
    for line_start, value in [("frames", "39"), ("duration", "1.267 s"), ("loop", "wrap"),
                              ("frame rate", "30.00 fps"), ("mean speed", "0.978 m/s"), ("verdict", "valid")]:
        assert any(line.startswith(line_start) and value in line for line in out.splitlines()), \
            (line_start, out)
    assert "root travel" in out


def test_info_json_by_name(deepmimic_dir, capsys):
    code = cli.main(["clips", "info", "kick", "--json", "--clips-dir", str(deepmimic_dir / "motions")])
    assert code == 0
    info = json.loads(capsys.readouterr().out)
    assert info["valid"] is True and info["error"] is None
    assert info["path"] == str(deepmimic_dir / "motions" / "humanoid3d_kick.txt")
    assert info["frames"] == 47
    assert info["duration_s"] == pytest.approx(1.53, abs=0.01)
    assert info["loop"] == "none"
    assert info["fps"] == pytest.approx(30.0, abs=0.01)
    assert info["root_travel_m"] > 0.5
    assert info["mean_speed_mps"] == pytest.approx(info["root_travel_m"] / info["duration_s"], rel=1e-3)
    assert info["max_quat_norm_error"] == pytest.approx(0.42, abs=0.01)


@pytest.mark.parametrize("name, frames, speed", [("slow_walk", 43, 0.65), ("squat", 61, 0.0)])
def test_info_on_authored_clips(capsys, name, frames, speed):
    assert cli.main(["clips", "info", name, "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["path"] == str(PROJECT_CLIPS / f"{name}.txt")
    assert info["frames"] == frames and info["loop"] == "wrap"
    assert info["mean_speed_mps"] == pytest.approx(speed, abs=0.01)
    assert info["path_speed_mps"] >= info["mean_speed_mps"] - 1e-6  # a straight clip: about the same
    assert abs(info["lowest_sole_m"][0]) < 0.01 and abs(info["lowest_sole_m"][1]) < 0.01


def test_info_gives_the_path_a_turning_clip_travels(tmp_path, capsys):
    """A clip whose root goes once round a circle of 1 m ends where it began: travel 0, path 2 pi m."""
    import math

    clip = json.loads((PROJECT_CLIPS / "slow_walk.txt").read_text())
    frames = clip["Frames"]
    for k, frame in enumerate(frames):
        angle = 2 * math.pi * k / (len(frames) - 1)
        frame[1], frame[3] = math.cos(angle), math.sin(angle)  # the root's x and its horizontal y (y-up file)
    circle = tmp_path / "circle.txt"
    circle.write_text(json.dumps({"Loop": "none", "Frames": frames}))
    assert cli.main(["clips", "info", str(circle), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["root_travel_m"] < 1e-3 and info["mean_speed_mps"] < 1e-3
    assert info["root_path_m"] == pytest.approx(2 * math.pi, rel=0.01)
    assert info["path_speed_mps"] == pytest.approx(info["root_path_m"] / info["duration_s"], rel=1e-3)
    assert cli.main(["clips", "info", str(circle)]) == 0
    assert f"{info['root_path_m']:.3f} m along its path" in capsys.readouterr().out  # in words too


def test_info_on_a_broken_file(tmp_path):
    bad = tmp_path / "broken.txt"
    bad.write_text('{"Loop": "wrap", "Frames": [[0.1, 1, 2], [0.1, 1, 2]]}')
    result = run_cli("clips", "info", str(bad))
    assert result.returncode == 2
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert str(bad) in lines[0] and "frame 0 (0-based)" in lines[0] and "expected 44" in lines[0]


def test_info_json_on_a_broken_file(tmp_path, capsys):
    bad = tmp_path / "nan.txt"
    bad.write_text('{"Loop": "wrap", "Frames": [[NaN], [0.1]]}')
    assert cli.main(["clips", "info", str(bad), "--json"]) == 2
    info = json.loads(capsys.readouterr().out)
    assert info["valid"] is False
    assert str(bad) in info["error"] and "frame 0 (0-based)" in info["error"]


def test_info_unknown_name(tmp_path, capsys):
    assert cli.main(["clips", "info", "no_such_clip", "--clips-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "unknown clip 'no_such_clip'" in err and str(tmp_path) in err


def test_list(deepmimic_dir, capsys):
    assert cli.main(["clips", "list", "--clips-dir", str(deepmimic_dir / "motions")]) == 0
    header, *rows = [line.split() for line in capsys.readouterr().out.splitlines()]
    assert header == ["clip", "source", "fits", "file"]
    by_name = {row[0]: row for row in rows}
    assert by_name["slow_walk"][1:] == ["project", "humanoid", str(PROJECT_CLIPS / "slow_walk.txt")]
    assert by_name["walk"][1:] == ["--clips-dir", "humanoid", str(deepmimic_dir / "motions" / "humanoid3d_walk.txt")]
    assert by_name["dog3d_trot"][2] == "dog3d"  # offered, but marked as the dog's
    assert len(by_name) == len(rows)


def test_subcommands_are_a_registry(monkeypatch, capsys):
    """Another subcommand (e.g. render) is one more entry: the parser and dispatcher pick it up."""
    assert set(clips_cmd.SUBCOMMANDS) == {"list", "info", "render", "import", "retarget"}

    def add(parser):
        parser.add_argument("clip")

    def run(args):
        print(f"rendered {args.clip}")
        return 0

    monkeypatch.setitem(clips_cmd.SUBCOMMANDS, "render", clips_cmd.Subcommand("render a clip", add, run))
    assert cli.main(["clips", "render", "walk"]) == 0
    assert capsys.readouterr().out == "rendered walk\n"


def test_clips_command_stays_jax_free():
    code = ("import argparse, sys; from mjxmimic.commands import clips; p = argparse.ArgumentParser(); "
            "clips.add_arguments(p); rc = clips.run(p.parse_args(['info', 'squat'])); "
            "sys.exit(3 if 'jax' in sys.modules else rc)")
    result = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True,
                            timeout=120, check=False)
    assert result.returncode == 0, result.stderr
    assert "valid" in result.stdout


def test_every_option_of_every_command_has_help_text():
    import argparse

    from mjxmimic.cli import build_parser

    def walk(parser):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in action.choices.values():
                    yield from walk(sub)
            elif not isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
                yield parser.prog, action

    missing = [f"{prog} {'/'.join(a.option_strings) or a.dest}" for prog, a in walk(build_parser()) if not a.help]
    assert not missing, missing


def test_info_missing_path_names_the_path_alone(tmp_path, capsys):
    missing = tmp_path / "none.txt"
    assert cli.main(["clips", "info", str(missing)]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].endswith(f"{missing}: no such clip file")
