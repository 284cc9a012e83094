"""Whether a clip's airborne stretches obey free fall, which `clips info` reports (and the
reports of `clips import` and `clips retarget`).

Off the ground, nothing but gravity acts on a body: its centre of mass falls at g and its angular
momentum about the centre of mass stays what it was at take-off. A clip that turns or lifts itself
in the air (an edited flip, a floaty jump) asks for what no simulated character can do, so an
episode started in such a stretch (reference state initialisation) may fall whatever the policy.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import mujoco
import numpy as np

from mjxmimic.core.character import Character
from mjxmimic.core.kinematics import ROOT_BODY
from mjxmimic.motion.clip import Clip, lowest_points
from mjxmimic.motion.library import build_motion_lib

AIRBORNE_HEIGHT = 0.02  # m: a frame whose lowest point is higher touches nothing
MIN_FRAMES = 3  # a parabola needs three heights
PATH_TOLERANCE = 0.02  # m between the centre of mass and the free-fall path nearest to it
MOMENTUM_TOLERANCE = 5.0  # kg m^2/s of change in angular momentum, and
MOMENTUM_SHARE = 0.25  # that share of its largest magnitude in the stretch


@dataclass(frozen=True)
class Flight:
    start_s: float
    end_s: float
    frames: int
    lowest_m: float  # the stretch's lowest point above the ground
    acceleration: tuple[float, float, float]  # fitted centre-of-mass acceleration, m/s^2, world axes
    path_error_m: float  # largest distance from the nearest free-fall path (any take-off, gravity's pull)
    momentum_start: float  # |angular momentum about the centre of mass|, kg m^2/s
    momentum_end: float
    momentum_change: float  # largest |L(t) - L(start)| in the stretch
    falls_freely: bool  # within PATH_TOLERANCE of a free-fall path
    keeps_momentum: bool

    @property
    def ballistic(self) -> bool:
        return self.falls_freely and self.keeps_momentum

    def as_dict(self) -> dict:
        """JSON-ready, rounded to mm and thousandths."""
        out = {k: (round(v, 3) if isinstance(v, float) else [round(x, 3) for x in v] if isinstance(v, tuple) else v)
               for k, v in asdict(self).items()}
        return out | {"ballistic": self.ballistic}


def whole_body_motion(model: mujoco.MjModel, data: mujoco.MjData, qpos: np.ndarray,
                      qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre of mass, its velocity and the angular momentum about it (world axes) of one state,
    computed in `data` (scratch)."""
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco.mj_forward(model, data)
    mujoco.mj_subtreeVel(model, data)
    return (data.subtree_com[ROOT_BODY].copy(), data.subtree_linvel[ROOT_BODY].copy(),
            data.subtree_angmom[ROOT_BODY].copy())


def _centre_of_mass_and_momentum(character: Character, qpos: np.ndarray,
                                 qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    data = mujoco.MjData(character.model)
    motion = [whole_body_motion(character.model, data, q, v) for q, v in zip(qpos, qvel)]
    return np.array([com for com, _, _ in motion]), np.array([momentum for _, _, momentum in motion])


def _stretches(airborne: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) frame of each run of airborne frames at least MIN_FRAMES long."""
    edges = np.diff(np.concatenate([[0], airborne.astype(int), [0]]))
    return [(int(a), int(b) - 1) for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))
            if b - a >= MIN_FRAMES]


def _free_fall_error(t: np.ndarray, com: np.ndarray, gravity: np.ndarray) -> float:
    """Largest distance between the centre of mass and the free-fall path (least squares over the
    take-off position and velocity) nearest to it."""
    unexplained = com - 0.5 * gravity * t[:, None] ** 2
    basis = np.stack([np.ones_like(t), t], axis=1)
    fit, *_ = np.linalg.lstsq(basis, unexplained, rcond=None)
    return float(np.linalg.norm(unexplained - basis @ fit, axis=1).max())


def flights(character: Character, clip: Clip) -> list[Flight]:
    """Every stretch of at least MIN_FRAMES frames with nothing within AIRBORNE_HEIGHT of the
    ground, with its fitted centre-of-mass acceleration and its angular momentum (from the frames'
    central-difference velocities), and whether both are what free fall allows."""
    lib = build_motion_lib([clip], character, velocity="central")
    qpos, qvel, times = lib.qpos.astype(np.float64), lib.qvel.astype(np.float64), lib.times.astype(np.float64)
    lowest = lowest_points(character, qpos)
    com, momentum = _centre_of_mass_and_momentum(character, qpos, qvel)
    gravity = np.asarray(character.model.opt.gravity, dtype=np.float64)
    out = []
    for first, last in _stretches(lowest > AIRBORNE_HEIGHT):
        span = slice(first, last + 1)
        t = times[span] - times[first]
        acceleration = 2.0 * np.polyfit(t, com[span], 2)[0]
        change = np.linalg.norm(momentum[span] - momentum[first], axis=1).max()
        size = np.linalg.norm(momentum[span], axis=1).max()
        path_error = _free_fall_error(t, com[span], gravity)
        out.append(Flight(
            start_s=float(times[first]), end_s=float(times[last]), frames=last - first + 1,
            lowest_m=float(lowest[span].min()), acceleration=tuple(float(a) for a in acceleration),
            path_error_m=path_error,
            momentum_start=float(np.linalg.norm(momentum[first])),
            momentum_end=float(np.linalg.norm(momentum[last])),
            momentum_change=float(change), falls_freely=bool(path_error <= PATH_TOLERANCE),
            keeps_momentum=bool(change <= max(MOMENTUM_TOLERANCE, MOMENTUM_SHARE * size))))
    return out


def describe(flight: dict, gravity: float) -> str:
    """One line for `clips info` from a Flight's as_dict()."""
    ax, ay, az = flight["acceleration"]
    failed = [what for what, ok in (("held up", flight["falls_freely"]), ("turned", flight["keeps_momentum"])) if not ok]
    verdict = ("ballistic" if not failed else
               f"NOT ballistic, {' and '.join(failed)} with nothing touching: a simulated body must leave the reference here")
    return (f"{flight['start_s']:.3f} .. {flight['end_s']:.3f} s ({flight['frames']} frames, {flight['lowest_m']:.3f} m up): "
            f"centre of mass accelerates {az:+.1f} m/s^2 vertically (free fall -{gravity:.2f}), "
            f"{np.hypot(ax, ay):.1f} horizontally, {100 * flight['path_error_m']:.1f} cm off the nearest free-fall path; "
            f"angular momentum {flight['momentum_start']:.1f} -> {flight['momentum_end']:.1f} kg m^2/s "
            f"(changes by up to {flight['momentum_change']:.1f}): {verdict}")
