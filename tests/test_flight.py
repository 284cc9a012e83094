"""A clip's airborne stretches are checked against free fall (mjxmimic.motion.flight)."""

from __future__ import annotations

import numpy as np
import pytest

from mjxmimic import cli
from mjxmimic.core import quat
from mjxmimic.core.character import load_character
from mjxmimic.motion.clip import Clip, load_clip_source
from mjxmimic.motion.flight import PATH_TOLERANCE, flights

FPS = 30.0
FRAMES = 25
HEIGHT = 2.0  # m: the root this high keeps every body off the ground


@pytest.fixture(scope="module")
def character():
    return load_character()


def thrown(character, vertical_acceleration: float = -9.81, spin_up: float = 0.0) -> Clip:
    """The humanoid's rest pose thrown up from HEIGHT, its root falling with the given
    acceleration and turning about its forward axis at spin_up * t rad/s."""
    t = np.arange(FRAMES) / FPS
    qpos = np.tile(character.model.qpos0, (FRAMES, 1))
    qpos[:, 0] = 0.5 * t
    qpos[:, 2] = HEIGHT + 3.0 * t + 0.5 * vertical_acceleration * t ** 2
    angle = 0.5 * spin_up * t ** 2
    qpos[:, 3:7] = quat.from_rotvec(angle[:, None] * np.array([1.0, 0.0, 0.0]))
    return Clip(name="thrown", path=None, loop=False, durations=np.full(FRAMES, 1 / FPS), qpos=qpos)


def test_a_thrown_body_is_ballistic(character):
    [flight] = flights(character, thrown(character))
    assert flight.ballistic
    assert flight.frames == FRAMES and flight.start_s == 0.0
    assert flight.path_error_m < 1e-3
    assert flight.acceleration[2] == pytest.approx(-9.81, abs=0.05)
    assert flight.momentum_change < 0.5


def test_a_body_that_lifts_itself_in_the_air_is_not(character):
    [flight] = flights(character, thrown(character, vertical_acceleration=-5.0))
    assert not flight.ballistic
    assert flight.path_error_m > PATH_TOLERANCE
    assert flight.acceleration[2] == pytest.approx(-5.0, abs=0.05)


def test_a_body_that_spins_itself_up_in_the_air_is_not(character):
    [flight] = flights(character, thrown(character, spin_up=30.0))
    assert not flight.ballistic
    assert flight.path_error_m < PATH_TOLERANCE  # it falls freely, but turns ever faster
    assert flight.momentum_end > flight.momentum_start + 10.0


def test_a_clip_on_the_ground_has_no_flight(character):
    assert flights(character, load_clip_source("squat", character)) == []


def test_deepmimic_clips(character, deepmimic_dir):
    """The run's strides are ballistic; the backflip turns itself in the air and the spin's hop
    rises against gravity, which no simulated character can follow."""
    motions = deepmimic_dir / "motions"
    run = flights(character, load_clip_source("run", character, motions))
    assert len(run) == 2 and all(f.ballistic for f in run)
    [backflip] = flights(character, load_clip_source("backflip", character, motions))
    assert not backflip.ballistic and backflip.momentum_change > 20.0
    hop = [f for f in flights(character, load_clip_source("spin", character, motions)) if not f.ballistic]
    assert len(hop) == 1 and hop[0].path_error_m > 0.05


def test_clips_info_reports_flights(character, deepmimic_dir, capsys):
    assert cli.main(["clips", "info", "backflip", "--clips-dir", str(deepmimic_dir / "motions")]) == 0
    out = capsys.readouterr().out
    [line] = [row for row in out.splitlines() if row.startswith("airborne")]
    assert "NOT ballistic" in line and "angular momentum" in line


def test_made_clips_report_their_airborne_stretches(character):
    """`clips retarget` and `clips import` carry the check in their reports."""
    from mjxmimic.motion.retarget import retarget

    [stretch] = retarget(thrown(character, vertical_acceleration=-5.0), character, character, None).report["airborne"]
    assert not stretch["ballistic"] and not stretch["falls_freely"] and stretch["keeps_momentum"]
