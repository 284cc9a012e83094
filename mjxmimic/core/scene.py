"""The physics scene: the character's MJCF at a physics rate and solver setting, plus one MuJoCo
contact sensor per character geom that can touch the floor.

Fall detection reads those sensors ("found": how many contacts the geom has with the floor), so it
works the same on MJX-JAX, MJX-Warp and MuJoCo C, none of which expose their contact lists alike.
Which geoms count as a fall is a mask over the sensors (`fall_mask`), chosen per clip at run time,
so one compiled model serves clips with different fall-contact sets.

With a terrain (mjxmimic.core.terrain), its boxes are static world geoms that collide as the
floor does (contype 0, conaffinity 1), the floor plane drops to the pit floor, and each sensor
counts every contact of its geom (no second geom named: MJX-JAX matches contact sensors by geom
only, and the character's geoms touch nothing but the world), so a chest on a step is a fall too.

With a ball (the throw task), a free sphere body is added after the character, so that the
character's qpos, qvel and bodies stay a prefix of the scene's (`nq`, `nv`, `nbody`) and the ball's
7 qpos and 6 qvel come last. It collides with the floor and the terrain only (contype 1,
conaffinity 0, as the character's geoms, which collide with nothing but the world; checked), has no
contact sensor, so it is never a fall and the character's observation does not see it as a body.
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np

from mjxmimic.core.character import Character
from mjxmimic.core.terrain import Terrain

FLOOR = "floor"
BALL = "_ball"
BALL_RGBA = (1.0, 0.55, 0.05, 1.0)  # orange: it stands out from the character


class Ball(NamedTuple):
    """A thrown ball (a baseball by default)."""

    radius_m: float = 0.037
    mass_kg: float = 0.145


class Scene(NamedTuple):
    model: mujoco.MjModel
    contact_geoms: np.ndarray  # (S,) the geom id that sensor i watches
    contact_adr: np.ndarray  # (S,) sensordata address of sensor i's "found" count
    nq: int  # the character's qpos, qvel and bodies: a prefix of the model's
    nv: int
    nbody: int
    ball: int = -1  # the ball's body id (the last body), -1 without one


def add_ball(spec: mujoco.MjSpec, ball: Ball, floor: mujoco.MjsGeom) -> None:
    """The ball: a free sphere body after the character's, colliding with the world's geoms only."""
    body = spec.worldbody.add_body()
    body.name = BALL
    body.add_freejoint()
    geom = body.add_geom()
    geom.type = mujoco.mjtGeom.mjGEOM_SPHERE
    geom.size = [ball.radius_m, 0.0, 0.0]
    geom.mass = ball.mass_kg
    geom.contype, geom.conaffinity = 1, 0
    geom.friction = floor.friction
    geom.rgba = list(BALL_RGBA)


def _touches_floor(model: mujoco.MjModel, g: int, floor: int) -> bool:
    """Whether geom g collides with the floor by MuJoCo's contype/conaffinity rule."""
    return model.geom_bodyid[g] != 0 and bool(
        (model.geom_contype[g] & model.geom_conaffinity[floor])
        or (model.geom_contype[floor] & model.geom_conaffinity[g]))


def add_terrain(spec: mujoco.MjSpec, terrain: Terrain) -> None:
    """The terrain's boxes as world geoms, each from the pit floor up to its top (the physics
    scene's and the renderer's)."""
    floor = spec.geom(FLOOR)
    floor.pos = [0.0, 0.0, -terrain.depth]
    for i, (cx, cy, hx, hy, top) in enumerate(np.asarray(terrain.boxes, np.float64)):
        geom = spec.worldbody.add_geom()
        geom.name = f"_terrain{i}"
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = [hx, hy, 0.5 * (top + terrain.depth)]
        geom.pos = [cx, cy, 0.5 * (top - terrain.depth)]
        geom.contype, geom.conaffinity = 0, 1
        geom.friction = floor.friction
        # shaded by the top's height, not by box: boxes that overlap at one height (a beam's
        # segments, a course's last ground and the pad after it) then show no flicker in renders
        tone = 0.05 * (round(top / 0.05) % 3)
        geom.rgba = [0.55 + tone, 0.5 + tone, 0.45 + tone, 1.0]


def build_scene(character: Character, physics_hz: int, solver_iterations: int, ls_iterations: int,
                terrain: Terrain | None = None, ball: Ball | None = None) -> Scene:
    """The character's model with contact sensors, at the given physics rate and solver settings,
    on a terrain's course if one is given, with a ball if one is given."""
    spec = mujoco.MjSpec.from_file(str(character.xml_path))
    base = character.model
    floor = mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_GEOM, FLOOR)
    if floor < 0:
        raise ValueError(f"{character.xml_path}: no geom named {FLOOR!r}")
    watched = [g for g in range(base.ngeom) if _touches_floor(base, g, floor)]
    if terrain is not None:
        add_terrain(spec, terrain)
    for g in watched:
        geom = spec.geoms[g]
        if not geom.name:
            geom.name = f"_geom{g}"
        sensor = spec.add_sensor()
        sensor.name = f"_floor_contact_{g}"
        sensor.type = mujoco.mjtSensor.mjSENS_CONTACT
        sensor.objtype = mujoco.mjtObj.mjOBJ_GEOM
        sensor.objname = geom.name
        if terrain is None:
            sensor.reftype = mujoco.mjtObj.mjOBJ_GEOM
            sensor.refname = FLOOR
        sensor.intprm[0] = 1  # data: "found" only
        sensor.intprm[1] = 0  # no reduction
        sensor.intprm[2] = 1  # one slot
    if ball is not None:
        add_ball(spec, ball, spec.geom(FLOOR))
    model = spec.compile()
    model.opt.timestep = 1.0 / physics_hz
    model.opt.iterations = solver_iterations
    model.opt.ls_iterations = ls_iterations
    adr = [model.sensor_adr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, f"_floor_contact_{g}")]
           for g in watched]
    ball_id = -1 if ball is None else model.nbody - 1
    if ball is not None:
        check_ball_collisions(model, ball_id)
    return Scene(model=model, contact_geoms=np.array(watched, dtype=np.int32),
                 contact_adr=np.array(adr, dtype=np.int32), nq=base.nq, nv=base.nv, nbody=base.nbody, ball=ball_id)


def check_ball_collisions(model: mujoco.MjModel, ball: int) -> None:
    """The ball must collide with the world's geoms and with none of the character's."""
    g = model.body_geomadr[ball]
    for other in range(model.ngeom):
        if other == g:
            continue
        collides = bool((model.geom_contype[g] & model.geom_conaffinity[other])
                        or (model.geom_contype[other] & model.geom_conaffinity[g]))
        if collides != (model.geom_bodyid[other] == 0):
            raise ValueError(f"the ball would {'' if collides else 'not '}collide with geom {other}")


def sensor_geoms(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per contact sensor: its geom's body, the geom's centre relative to that body's centre of
    mass (body frame), and the geom's bounding-sphere radius."""
    m, g = scene.model, scene.contact_geoms
    body = m.geom_bodyid[g]
    return body, (m.geom_pos[g] - m.body_ipos[body]).astype(np.float32), m.geom_rbound[g].astype(np.float32)


def fall_mask(scene: Scene, character: Character, spec: str) -> np.ndarray:
    """(S,) bool: which contact sensors end an episode for the fall-contact set `spec`."""
    bodies = np.array(character.fall_bodies(spec))
    return np.isin(scene.model.geom_bodyid[scene.contact_geoms], bodies)
