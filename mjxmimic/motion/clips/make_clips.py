"""Keyframe the project's own clips in joint space and write them in DeepMimic's clip format.

    python -m mjxmimic.motion.clips.make_clips            # (re)write mjxmimic/motion/clips/*.txt
    python -m mjxmimic.motion.clips.make_clips --check    # exit 1 if a committed file differs from what this writes
    python -m mjxmimic.motion.clips.make_clips --out DIR  # write elsewhere

Clips (30 frames per second; looping "wrap" but for pitch):

- slow_walk: a slow forward walk, 1.4 s per cycle (two steps). Legs swing, knees flex in swing
  (about 60 deg), the stance foot rolls heel -> flat -> toe, arms counter-swing, the pelvis turns
  and drops a little. The project's default clip.
- squat: stand -> squat (thighs about level) -> stand in 2 s, feet flat and fixed, arms raised
  forward; the torso lean is solved per frame so the centre of mass stays over the feet.
- wave: stand, raise the right arm, wave three times, lower it, in 3 s.
- pitch: an overhand right-handed throw towards +x, not looping ("none"), 2.6 s: set (0 - 0.3 s),
  wind-up with the chest turned away and the arm cocked behind (to 0.9 s), the throw (chest turns
  through, the arm whips over and the elbow straightens), the ball let go at PITCH_RELEASE_S =
  1.1 s, hand high and ahead of the shoulder, follow-through across the body, back to the set by
  2.6 s. Feet stay planted (the pelvis turns 20 deg each way, so they slide a few cm). The throw
  task (mjxmimic.task.goals) releases its ball at that time (task.release_s).

Everything is keyframed in joint space with angles that mean something in the world frame (thigh
pitch, foot pitch, pelvis turn) and turned into each joint's local quaternion. MuJoCo forward
kinematics on the character then sets the root's height so that the lowest point of the body
touches the floor in every frame. The walk's root moves forward at a constant speed, and in stance
each thigh's pitch is solved (two-link leg) so that the planted foot does not slide while it rolls
heel -> flat -> toe. Limb lengths and the sole's corners come from the MJCF. The last frame of each
clip is its first shifted by the cycle's travel, so cycles join without a seam. Output is
deterministic (fixed decimals).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import mujoco
import numpy as np

from mjxmimic.core.character import Character, load_character
from mjxmimic.motion.clip import Clip, format_clip, lowest_points

HERE = Path(__file__).resolve().parent
FPS = 30
DEG = math.pi / 180
LEFT, RIGHT = 1.0, -1.0  # side signs: +y is the character's left


# ------------------------------------------------------------------------------------ quaternions


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


def qinv(q: np.ndarray) -> np.ndarray:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def rot(axis: str, degrees: float) -> np.ndarray:
    half = 0.5 * degrees * DEG
    q = np.array([math.cos(half), 0.0, 0.0, 0.0])
    q["xyz".index(axis) + 1] = math.sin(half)
    return q


def chain(*qs: np.ndarray) -> np.ndarray:
    out = np.array([1.0, 0.0, 0.0, 0.0])
    for q in qs:
        out = qmul(out, q)
    return out


# Conventions (z-up, x forward, y left). A limb hangs along -z. rot("y", -a) swings it forward by a
# degrees; rot("y", +a) tilts a foot toes-down by a. Knees (hinge about -y, range [-3.14, 0]) flex
# with negative angles, elbows (about -y, [0, 3.14]) with positive ones.


# ---------------------------------------------------------------------------------- curves


def hermite(x: float, p1: float, v1: float, m1: float, p2: float, v2: float, m2: float) -> float:
    """Cubic Hermite segment from (p1, v1) with slope m1 to (p2, v2) with slope m2."""
    h = p2 - p1
    s = (x - p1) / h
    return ((2 * s**3 - 3 * s**2 + 1) * v1 + (s**3 - 2 * s**2 + s) * h * m1
            + (-2 * s**3 + 3 * s**2) * v2 + (s**3 - s**2) * h * m2)


def periodic_curve(keys: list[tuple[float, float]], phase: float) -> float:
    """Monotone (PCHIP, no overshoot) interpolation through (phase, value) keys, period 1.

    Keys are sorted, phases in [0, 1), the first at 0.
    """
    n = len(keys)
    ps = [keys[k % n][0] + k // n for k in range(-2, n + 2)]  # unwrapped, index shifted by 2
    vs = [keys[k % n][1] for k in range(-2, n + 2)]
    phase %= 1.0
    i = max(k for k in range(2, n + 2) if ps[k] <= phase)

    def slope(k: int) -> float:
        h0, h1 = ps[k] - ps[k - 1], ps[k + 1] - ps[k]
        d0, d1 = (vs[k] - vs[k - 1]) / h0, (vs[k + 1] - vs[k]) / h1
        if d0 * d1 <= 0:
            return 0.0
        w0, w1 = 2 * h1 + h0, h1 + 2 * h0
        return (w0 + w1) / (w0 / d0 + w1 / d1)

    return hermite(phase, ps[i], vs[i], slope(i), ps[i + 1], vs[i + 1], slope(i + 1))


def smoothstep(x: float) -> float:
    x = min(1.0, max(0.0, x))
    return x * x * (3 - 2 * x)


# ------------------------------------------------------------------------------------ posing


class Poser:
    """Turns world-frame segment orientations into the character's qpos, and measures poses."""

    def __init__(self, character: Character):
        self.character = character
        self.model = character.model
        self.data = mujoco.MjData(self.model)
        self.adr = {j.name: j.qpos_adr for j in character.joints}
        self.body = {name: i + 1 for i, name in enumerate(character.body_names)}
        # Leg geometry from the MJCF: segment lengths, hip offset, sole corners (ankle frame).
        pos = self.model.body_pos
        self.thigh_len = float(-pos[self.body["right_knee"]][2])
        self.shank_len = float(-pos[self.body["right_ankle"]][2])
        self.hip_width = float(pos[self.body["left_hip"]][1])
        foot = next(g for g in range(self.model.ngeom)
                    if self.model.geom_bodyid[g] == self.body["right_ankle"])
        (cx, _, cz), (hx, _, hz) = self.model.geom_pos[foot], self.model.geom_size[foot]
        self.sole = {"heel": np.array([cx - hx, 0.0, cz - hz]), "toe": np.array([cx + hx, 0.0, cz - hz])}

    def pose(self, root: np.ndarray, chest: np.ndarray, head: np.ndarray,
             legs: dict[float, tuple[np.ndarray, float, np.ndarray]],
             arms: dict[float, tuple[np.ndarray, float]]) -> np.ndarray:
        """qpos (root at the origin) from world orientations.

        legs[side] = (thigh, knee flexion deg, foot); arms[side] = (upper arm, elbow flexion deg).
        """
        q = np.zeros(self.model.nq)
        q[3:7] = root
        q[self.adr["chest"]:][:4] = qmul(qinv(root), chest)
        q[self.adr["neck"]:][:4] = qmul(qinv(chest), head)
        for side, (thigh, knee, foot) in legs.items():
            name = "left" if side == LEFT else "right"
            shank = qmul(thigh, rot("y", knee))
            q[self.adr[f"{name}_hip"]:][:4] = qmul(qinv(root), thigh)
            q[self.adr[f"{name}_knee"]] = -knee * DEG
            q[self.adr[f"{name}_ankle"]:][:4] = qmul(qinv(shank), foot)
        for side, (upper, elbow) in arms.items():
            name = "left" if side == LEFT else "right"
            q[self.adr[f"{name}_shoulder"]:][:4] = qmul(qinv(chest), upper)
            q[self.adr[f"{name}_elbow"]] = elbow * DEG
        for adr in [3] + [j.qpos_adr for j in self.character.joints if j.qpos_width == 4]:
            q[adr:adr + 4] /= np.linalg.norm(q[adr:adr + 4])
        return q

    def kinematics(self, qpos: np.ndarray) -> mujoco.MjData:
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        return self.data

    def point(self, qpos: np.ndarray, body: str, local: np.ndarray) -> np.ndarray:
        d = self.kinematics(qpos)
        b = self.body[body]
        return d.xpos[b] + d.xmat[b].reshape(3, 3) @ local

    def com(self, qpos: np.ndarray) -> np.ndarray:
        return self.kinematics(qpos).subtree_com[1].copy()

    def ground(self, qpos: np.ndarray) -> np.ndarray:
        """The pose lifted or lowered so that its lowest point is at z = 0."""
        out = qpos.copy()
        out[2] -= lowest_points(self.character, qpos[None])[0]
        return out


def make_clip(name: str, qpos: list[np.ndarray], loop: bool = True) -> Clip:
    frames = np.asarray(qpos)
    return Clip(name=name, path=None, loop=loop, durations=np.full(len(frames), 1.0 / FPS), qpos=frames)


# ------------------------------------------------------------------------------------ slow walk

WALK_CYCLE_S = 1.4  # two steps
WALK_SPEED = 0.65  # m/s, constant: the root moves WALK_SPEED * t forward
TOE_OFF = 0.6  # stance is leg phase [0, TOE_OFF), 0 = this foot's heel strike
UNDER_HIP = 0.25  # leg phase at which the flat foot's ankle is right under the hip
# Leg keys over the leg's own phase (degrees).
KNEE = [(0.0, 3), (0.1, 12), (0.3, 6), (0.45, 7), (0.55, 22), (0.6, 35), (0.7, 58), (0.8, 48), (0.88, 28),
        (0.95, 8)]  # flexion
# Foot pitch (toes down +): heel strike toes up, flat, heel rise from 0.35, toe-off.
FOOT = [(0.0, -14), (0.1, 0), (0.35, 0), (0.5, 8), (0.6, 22), (0.7, 12), (0.8, 0), (0.9, -8)]
SWING_THIGH = [(0.78, 12.0), (0.9, 4.0)]  # forward pitch in swing; the last is added to heel strike's


def _walk_root(phase: float) -> np.ndarray:
    turn = 4.0 * math.cos(2 * math.pi * phase)  # pelvis turns the forward leg's side forward
    drop = -3.0 * math.sin(2 * math.pi * phase)  # and drops on the swing side
    return chain(rot("z", turn), rot("x", drop), rot("y", 3.0))


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return qmul(qmul(q, np.array([0.0, *v])), qinv(q))[1:]


class Leg:
    """One leg's thigh pitch over its phase: solved in stance so the planted foot does not slide."""

    def __init__(self, poser: Poser, side: float, offset: float):
        self.side, self.offset = side, offset  # offset: leg phase - cycle phase
        self.thigh_len, self.shank_len, self.sole = poser.thigh_len, poser.shank_len, poser.sole
        hip = np.array([0.0, side * poser.hip_width, 0.0])
        cycle = WALK_CYCLE_S * WALK_SPEED

        def hip_x(leg_phase: float) -> float:  # hip's forward position (root x + pelvis turn)
            phase = leg_phase - offset
            return cycle * phase + _rotate(_walk_root(phase), hip)[0]

        self._hip_x = hip_x
        self._foot_x = self._ankle_x(UNDER_HIP) - hip_x(UNDER_HIP)
        t0, t1 = self._stance(0.0), self._stance(TOE_OFF - 1e-9)
        m0, m1 = (self._stance(2e-4) - t0) / 2e-4, (t1 - self._stance(TOE_OFF - 2e-4)) / (2e-4 - 1e-9)
        mid = [(p, v + (t0 if i == len(SWING_THIGH) - 1 else 0.0)) for i, (p, v) in enumerate(SWING_THIGH)]
        self._swing = [(TOE_OFF, t1, m1)] + [(p, v, None) for p, v in mid] + [(1.0, t0, m0)]

    def _ankle_x(self, leg_phase: float) -> float:
        """Ankle x of the planted foot, from where it lies flat: it rolls on the heel, then the toe."""
        pitch = periodic_curve(FOOT, leg_phase)
        pivot = self.sole["heel"] if pitch < 0 else self.sole["toe"]
        return float(pivot[0] + _rotate(rot("y", pitch), -pivot)[0])

    def _stance(self, leg_phase: float) -> float:
        """Thigh pitch that puts the ankle at its planted place (bisection on the two-link leg)."""
        dx = self._ankle_x(leg_phase) - self._hip_x(leg_phase) - self._foot_x
        knee = periodic_curve(KNEE, leg_phase) * DEG
        lo, hi = -80 * DEG, 80 * DEG
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if self.thigh_len * math.sin(mid) + self.shank_len * math.sin(mid - knee) < dx:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi) / DEG

    def thigh(self, leg_phase: float) -> float:
        leg_phase %= 1.0
        if leg_phase < TOE_OFF:
            return self._stance(leg_phase)
        keys = self._swing
        i = max(k for k in range(len(keys) - 1) if keys[k][0] <= leg_phase)

        def slope(k: int) -> float:
            if keys[k][2] is not None:
                return keys[k][2]
            return (keys[k + 1][1] - keys[k - 1][1]) / (keys[k + 1][0] - keys[k - 1][0])

        (p1, v1, _), (p2, v2, _) = keys[i], keys[i + 1]
        return hermite(leg_phase, p1, v1, slope(i), p2, v2, slope(i + 1))


def walk_pose(poser: Poser, legs: dict[float, Leg], phase: float) -> np.ndarray:
    """The walk's pose at cycle phase 0..1 (0 = right heel strike), root at the origin."""
    root = _walk_root(phase)
    turn = 4.0 * math.cos(2 * math.pi * phase)
    chest = chain(rot("z", -0.75 * turn), rot("y", 5.0))  # the chest turns against the pelvis
    head = rot("y", 0.0)
    leg_poses, arms = {}, {}
    for side, leg in legs.items():
        leg_phase = phase + leg.offset
        leg_poses[side] = (rot("y", -leg.thigh(leg_phase)), periodic_curve(KNEE, leg_phase),
                           rot("y", periodic_curve(FOOT, leg_phase)))
        swing = 2.0 - 14.0 * math.cos(2 * math.pi * (leg_phase - 0.05))  # forward as the leg goes back
        arms[side] = (chain(rot("x", side * 6.0), rot("y", -swing)), 22.0 + 0.5 * (swing - 2.0))
    return poser.pose(root, chest, head, leg_poses, arms)


def slow_walk(poser: Poser) -> Clip:
    n = round(WALK_CYCLE_S * FPS)  # frame intervals per cycle
    legs = {RIGHT: Leg(poser, RIGHT, 0.0), LEFT: Leg(poser, LEFT, 0.5)}
    poses = []
    for k in range(n + 1):
        q = poser.ground(walk_pose(poser, legs, (k % n) / n))
        q[0] = WALK_SPEED * k / FPS
        poses.append(q)
    return make_clip("slow_walk", poses)


# ----------------------------------------------------------------------------------- squat

SQUAT_S = 2.0
SQUAT_STAND_S = 0.2  # standing still at each end


def squat_pose(poser: Poser, depth: float) -> np.ndarray:
    """Stand (0) to squat (1): thighs pitch forward 85 deg, shins 30 deg, feet flat, arms forward.

    The torso lean (pelvis 60 %, chest the rest) is solved so that the centre of mass stays over
    the feet: above the ankles when standing, 3 cm in front of them at the bottom.
    """
    thigh = rot("y", -85.0 * depth)
    knee = 115.0 * depth
    legs = {side: (thigh, knee, rot("y", 0.0)) for side in (LEFT, RIGHT)}
    reach = 80.0 * depth
    arms = {side: (chain(rot("x", side * 5.0), rot("y", -reach)), 10.0 + 10.0 * depth)
            for side in (LEFT, RIGHT)}

    def at(lean: float) -> np.ndarray:
        return poser.pose(rot("y", 0.6 * lean), rot("y", lean), rot("y", 0.3 * lean), legs, arms)

    def balance(lean: float) -> float:
        q = at(lean)
        return poser.com(q)[0] - (poser.point(q, "right_ankle", np.zeros(3))[0] + 0.03 * depth)

    lo, hi = -15.0, 80.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if balance(mid) < 0 else (lo, mid)
    return at(0.5 * (lo + hi))


def squat(poser: Poser) -> Clip:
    n = round(SQUAT_S * FPS)
    poses = []
    for k in range(n):
        u = (k / FPS - SQUAT_STAND_S) / (SQUAT_S - 2 * SQUAT_STAND_S)
        depth = 0.5 - 0.5 * math.cos(2 * math.pi * min(1.0, max(0.0, u)))
        q = poser.ground(squat_pose(poser, depth))
        q[0] = -poser.point(q, "right_ankle", np.zeros(3))[0]  # feet stay where they stand
        poses.append(q)
    return make_clip("squat", poses + [poses[0].copy()])


# ------------------------------------------------------------------------------------- wave

WAVE_S = 3.0


def wave_pose(poser: Poser, t: float) -> np.ndarray:
    """Right arm raised to the side, forearm up, waving by the elbow; the left arm relaxed."""
    up = smoothstep(t / 0.6) * (1.0 - smoothstep((t - 2.4) / 0.6))
    waving = smoothstep((t - 0.5) / 0.2) * (1.0 - smoothstep((t - 2.3) / 0.2))
    wag = 25.0 * waving * math.sin(2 * math.pi * 3 * (t - 0.6) / 1.8)  # three waves in 1.8 s
    right = (chain(rot("x", RIGHT * (6.0 + 94.0 * up)), rot("z", -90.0 * up)), 12.0 + 78.0 * up + wag)
    left = (chain(rot("x", LEFT * 6.0), rot("y", -3.0)), 12.0)
    chest = chain(rot("x", -3.0 * up), rot("y", 1.0))  # lean a little away from the raised arm
    legs = {side: (rot("y", 0.0), 2.0, rot("y", 0.0)) for side in (LEFT, RIGHT)}
    q = poser.pose(rot("y", 0.0), chest, rot("z", -10.0 * up), legs, {RIGHT: right, LEFT: left})
    return poser.ground(q)


def wave(poser: Poser) -> Clip:
    n = round(WAVE_S * FPS)
    poses = [wave_pose(poser, k / FPS) for k in range(n)]
    return make_clip("wave", poses + [poses[0].copy()])


# ------------------------------------------------------------------------------------ pitch

PITCH_S = 2.6
PITCH_RELEASE_S = 1.1  # the ball leaves the hand (task.release_s of the throw task)
# (time s, degrees) keys; the first and last are the set pose, so the periodic curve starts and
# ends at rest
PELVIS_YAW = [(0.0, 0), (0.3, 0), (0.9, -20), (1.1, 10), (1.35, 20), (1.9, 10), (2.6, 0)]
CHEST_YAW = [(0.0, 0), (0.3, 0), (0.9, -50), (1.1, 0), (1.3, 35), (1.9, 20), (2.6, 0)]
CHEST_PITCH = [(0.0, 0), (0.3, 0), (0.9, -8), (1.1, 10), (1.4, 30), (1.9, 12), (2.6, 0)]  # + leans forward
ARM_RAISE = [(0.0, 8), (0.3, 20), (0.9, 95), (1.1, 100), (1.35, 60), (1.9, 25), (2.6, 8)]  # from the side
ARM_SWING = [(0.0, 0), (0.3, 20), (0.9, -30), (1.1, 0), (1.3, 50), (1.9, 40), (2.6, 0)]  # + forward
ARM_TWIST = [(0.0, 0), (0.3, -30), (0.9, -130), (1.05, -145), (1.1, -115), (1.15, -40), (1.35, 0),
             (2.6, 0)]  # about the upper arm; -90 holds the flexed forearm up, below that it lays back
ELBOW = [(0.0, 15), (0.3, 60), (0.9, 95), (1.1, 90), (1.25, 25), (1.9, 30), (2.6, 15)]
GLOVE = [(0.0, 5), (0.3, 20), (0.9, 80), (1.1, 40), (1.35, 10), (2.6, 5)]  # left arm forward


def _keyed(keys: list[tuple[float, float]], t: float) -> float:
    return periodic_curve([(k / PITCH_S, v) for k, v in keys[:-1]], t / PITCH_S)


def pitch_pose(poser: Poser, t: float) -> np.ndarray:
    """The throw at time t: world turns of pelvis and chest, the right arm raised from the side,
    swung forward about the vertical and twisted about its own axis, the elbow flexed."""
    pelvis, chest_yaw = _keyed(PELVIS_YAW, t), _keyed(CHEST_YAW, t)
    root = rot("z", pelvis)
    chest = chain(rot("z", chest_yaw), rot("y", _keyed(CHEST_PITCH, t)))
    head = rot("z", 0.3 * chest_yaw)
    right = (chain(rot("z", chest_yaw + _keyed(ARM_SWING, t)), rot("x", RIGHT * _keyed(ARM_RAISE, t)),
                   rot("z", _keyed(ARM_TWIST, t))), _keyed(ELBOW, t))
    left = (chain(rot("z", chest_yaw), rot("x", LEFT * 8.0), rot("y", -_keyed(GLOVE, t))), 20.0)
    legs = {side: (rot("z", pelvis), 6.0, rot("z", pelvis)) for side in (LEFT, RIGHT)}
    return poser.ground(poser.pose(root, chest, head, legs, {RIGHT: right, LEFT: left}))


def pitch(poser: Poser) -> Clip:
    n = round(PITCH_S * FPS)
    return make_clip("pitch", [pitch_pose(poser, k / FPS) for k in range(n + 1)], loop=False)


# -------------------------------------------------------------------------------------- output

BUILDERS = {"slow_walk.txt": slow_walk, "squat.txt": squat, "wave.txt": wave, "pitch.txt": pitch}


def build_clips(character: Character | None = None) -> dict[str, Clip]:
    """File name -> Clip (z-up qpos) for every authored clip."""
    poser = Poser(character or load_character())
    return {fname: build(poser) for fname, build in BUILDERS.items()}


def clip_texts(character: Character | None = None) -> dict[str, str]:
    """File name -> the exact DeepMimic JSON text this script writes."""
    character = character or load_character()
    comment = "authored by the mjxmimic project: clips/make_clips.py (regenerate, do not edit)"
    return {fname: format_clip(clip, character, comment=comment)
            for fname, clip in build_clips(character).items()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE, help="folder to write to (default: clips/)")
    parser.add_argument("--check", action="store_true", help="compare with the files in --out, write nothing")
    args = parser.parse_args(argv)
    stale = []
    for fname, text in clip_texts().items():
        path = args.out / fname
        if args.check:
            if not path.is_file() or path.read_text() != text:
                stale.append(fname)
        else:
            path.write_text(text)
            print(f"wrote {path}")
    if stale:
        print(f"out of date (run python -m mjxmimic.motion.clips.make_clips): {', '.join(stale)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
