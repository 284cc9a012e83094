"""Headless videos: a policy on MuJoCo's CPU simulator with its reference motion as a ghost, or a
clip on its own. numpy + mujoco + imageio (the "render" extra); no JAX.

OpenGL backend: MuJoCo reads MUJOCO_GL when `mujoco` is first imported. If it is unset (or asks
for a window where there is no display), `setup_gl()` picks a headless one: EGL when an EGL
driver is installed (NVIDIA's on a GPU machine, Mesa's software llvmpipe on a CPU machine), else
OSMesa. Debian packages: EGL = libegl1 libegl-mesa0 libgl1-mesa-dri; OSMesa = libosmesa6.
Set MUJOCO_GL=egl|osmesa to choose yourself.

The ghost is a second copy of the character (MjSpec attach, names prefixed "ghost/") whose geoms
are translucent (alpha 0.3), tinted, and collide with nothing; it is never simulated, only posed
by the reference qpos each frame. The camera follows the simulated root from the side.
"""

from __future__ import annotations

import ctypes.util
import os
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

from mjxmimic.core.config import playback_config
from mjxmimic.core.errors import UserError

GHOST_PREFIX = "ghost/"
GHOST_RGBA = (1.0, 0.62, 0.25, 0.3)
PUSH_RGBA = (0.9, 0.1, 0.1, 1.0)
GOAL_RGBA = (0.1, 0.75, 0.2, 1.0)
TARGET_RGBA = (0.1, 0.75, 0.2, 0.6)  # the throw target's disc on the floor
PUSH_ARROW_M_PER_N = 1.0 / 500.0  # arrow length per newton of push
EGL_VENDOR_DIRS = ("/usr/share/glvnd/egl_vendor.d", "/etc/glvnd/egl_vendor.d")
APT_HINT = "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri (EGL) or libosmesa6 (OSMesa)"
HEADLESS = ("egl", "osmesa")
VIDEO_SUFFIXES = (".mp4", ".m4v", ".mov", ".mkv")
STRIP_FRAMES = 8


def _has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _egl_available() -> bool:
    if ctypes.util.find_library("EGL") is None:
        return False
    return any(Path(d).is_dir() and any(Path(d).glob("*.json")) for d in EGL_VENDOR_DIRS)


def _osmesa_available() -> bool:
    return ctypes.util.find_library("OSMesa") is not None


def default_backend() -> str:
    """The headless backend this machine can use: egl if an EGL driver is there, else osmesa."""
    if _egl_available():
        return "egl"
    if _osmesa_available():
        return "osmesa"
    raise UserError(f"no headless OpenGL found for rendering: {APT_HINT}, or set MUJOCO_GL")


def setup_gl() -> str:
    """Choose MuJoCo's GL backend for offscreen rendering; call before the first Renderer.

    Respects MUJOCO_GL when set (glfw only where a display exists). When mujoco was already
    imported with a window backend, switches its GLContext class to the headless one.
    """
    want = os.environ.get("MUJOCO_GL", "").lower().strip()
    if not sys.platform.startswith("linux"):
        return want  # macOS (CGL) and Windows (WGL) render offscreen without a choice to make
    if want in ("", "glfw", "enable", "enabled", "on", "true", "1") and not (want and _has_display()):
        want = default_backend()
        os.environ["MUJOCO_GL"] = want
    available = {"egl": _egl_available, "osmesa": _osmesa_available}
    if want in available and not available[want]():
        # before mujoco is imported: with the library missing, its import fails deep in PyOpenGL
        raise UserError(f"MUJOCO_GL={want}, but no {want.upper()} library is installed: {APT_HINT}, "
                        f"or unset MUJOCO_GL")
    if "mujoco" not in sys.modules:
        return want
    from mujoco.rendering.classic import gl_context

    chosen = getattr(gl_context, "_MUJOCO_GL", "")
    if want in HEADLESS and chosen != want:
        # mujoco was imported before MUJOCO_GL was set: swap in the headless context class.
        try:
            if want == "egl":
                from mujoco.egl import GLContext
            else:
                from mujoco.osmesa import GLContext
        except (ImportError, RuntimeError) as err:
            raise UserError(f"cannot use MUJOCO_GL={want} for rendering ({err}); {APT_HINT}") from None
        import mujoco

        gl_context.GLContext = GLContext
        mujoco.GLContext = GLContext
    return want


def _imageio():
    try:
        import imageio.v2 as imageio
        import imageio_ffmpeg  # noqa: F401 (the ffmpeg binary imageio uses for mp4)
    except ImportError:
        raise UserError("writing videos needs imageio and imageio-ffmpeg (pip install 'mjxmimic[render]')") from None
    return imageio


def ghost_model(character_xml: str | Path, ghost: bool = True, width: int = 640, height: int = 480,
                terrain: Any = None):
    """An MjModel of the character (qpos[:nq]) plus, with ghost=True, its translucent copy
    (qpos[nq:2nq]), on the terrain's course if one is given; the offscreen buffer at least
    width x height."""
    import mujoco

    def load(src):
        return mujoco.MjSpec.from_file(str(src)) if isinstance(src, Path) else mujoco.MjSpec.from_string(src)

    spec = load(character_xml)
    spec.visual.global_.offwidth = max(int(spec.visual.global_.offwidth), width)
    spec.visual.global_.offheight = max(int(spec.visual.global_.offheight), height)
    if terrain is not None:
        from mjxmimic.core.scene import add_terrain

        add_terrain(spec, terrain)
    if ghost:
        copy = load(character_xml)
        root = copy.worldbody.first_body()
        for geom in copy.geoms:
            geom.rgba = list(GHOST_RGBA)
            geom.contype = 0
            geom.conaffinity = 0
        spec.worldbody.add_frame().attach_body(root, GHOST_PREFIX, "")
    return spec.compile()


class Scene:
    """Offscreen renderer of a character (and its ghost) posed by qpos; a side-on follow camera."""

    def __init__(self, character_xml: str | Path, nq: int, ghost: bool = True, width: int = 640,
                 height: int = 480, distance: float = 3.5, azimuth: float = 90.0, elevation: float = -12.0,
                 terrain: Any = None):
        setup_gl()
        import mujoco

        self.nq = nq
        self.ghost = ghost
        self.model = ghost_model(character_xml, ghost, width, height, terrain)
        self.data = mujoco.MjData(self.model)
        try:
            self.renderer = mujoco.Renderer(self.model, height=height, width=width)
        except Exception as err:  # noqa: BLE001 (GL errors come in many types)
            backend = os.environ.get("MUJOCO_GL", "")
            raise UserError(f"cannot open an offscreen OpenGL context (MUJOCO_GL={backend}): "
                            f"{str(err).splitlines()[0] if str(err) else type(err).__name__}; {APT_HINT}") from None
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.camera.distance = distance
        self.camera.azimuth = azimuth
        self.camera.elevation = elevation
        self._lookat: np.ndarray | None = None

    def frame(self, qpos: Any, ghost_qpos: Any | None = None,
              arrows: Iterable[tuple[Any, Any, Any]] = (), markers: Iterable[tuple[int, Any, Any, Any]] = (),
              focus: Any = None) -> np.ndarray:
        """(height, width, 3) uint8 image of the pose(s) (the character's part of qpos), with `arrows`
        and `markers` (`decorate`) in world coordinates (a push, a goal, a thrown ball); the camera
        follows `focus` (x, y), by default the root."""
        import mujoco

        d = self.data
        d.qpos[: self.nq] = qpos[: self.nq]
        if self.ghost:
            d.qpos[self.nq : 2 * self.nq] = qpos[: self.nq] if ghost_qpos is None else ghost_qpos[: self.nq]
        mujoco.mj_forward(self.model, d)
        x, y = (d.qpos[0], d.qpos[1]) if focus is None else focus
        target = np.array([x, y, 0.8])
        # Follow the root smoothly (a critically damped look-at keeps the floor from jittering).
        self._lookat = target if self._lookat is None else self._lookat + 0.2 * (target - self._lookat)
        self.camera.lookat[:] = self._lookat
        self.renderer.update_scene(d, camera=self.camera)
        decorate(self.renderer.scene, arrows, markers)
        return self.renderer.render()

    def close(self) -> None:
        self.renderer.close()


def decorate(scene: Any, arrows: Iterable[tuple[Any, Any, Any]] = (),
             markers: Iterable[tuple[int, Any, Any, Any]] = ()) -> None:
    """Add arrows (tail, head, rgba) and markers (mjtGeom type, centre, size as a model geom's:
    a cylinder's radius and half-height, rgba) to an MjvScene (a renderer's, or a viewer's
    user_scn), as far as it has room."""
    import mujoco

    for tail, head, rgba in arrows:
        if scene.ngeom >= scene.maxgeom:
            return
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), np.eye(3).ravel(),
                            np.array(rgba, np.float32))
        mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_ARROW, 0.04, np.asarray(tail, np.float64),
                             np.asarray(head, np.float64))
        scene.ngeom += 1
    for kind, centre, size, rgba in markers:
        if scene.ngeom >= scene.maxgeom:
            return
        mujoco.mjv_initGeom(scene.geoms[scene.ngeom], kind, np.asarray(size, np.float64), np.asarray(centre, np.float64),
                            np.eye(3).ravel(), np.array(rgba, np.float32))
        scene.ngeom += 1


def check_video_path(path: Path) -> None:
    """Fail early, before anything is rendered, on an --out that is neither a video file name
    nor a .png (a frame strip)."""
    if Path(path).suffix.lower() not in VIDEO_SUFFIXES + (".png",):
        raise UserError(f"--out {path}: expected a video file name ending in .mp4 (or .png for a frame strip)")


def write_strip(frames: Iterable[np.ndarray], path: Path, count: int = STRIP_FRAMES) -> int:
    """`count` frames spread evenly over the episode, side by side in one PNG; returns the number
    of frames rendered. Nothing half-written."""
    images = list(frames)
    if not images:
        raise UserError(f"--out {path}: no frames to write")
    picks = np.unique(np.linspace(0, len(images) - 1, min(count, len(images))).round().astype(int))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".part" + path.suffix)
    _imageio().imwrite(str(tmp), np.concatenate([images[i] for i in picks], axis=1))
    tmp.replace(path)
    return len(images)


def write_frames(frames: Iterable[np.ndarray], path: Path, fps: float) -> int:
    """A video, or for a .png a frame strip."""
    if Path(path).suffix.lower() == ".png":
        return write_strip(frames, path)
    return write_video(frames, path, fps)


def write_video(frames: Iterable[np.ndarray], path: Path, fps: float) -> int:
    """Write frames to an mp4 (H.264); returns the number of frames. Nothing half-written."""
    imageio = _imageio()
    path = Path(path)
    check_video_path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".part" + path.suffix)
    n = 0
    writer = imageio.get_writer(str(tmp), fps=fps, codec="libx264", quality=7, macro_block_size=16,
                                pixelformat="yuv420p", ffmpeg_log_level="error")
    try:
        for image in frames:
            writer.append_data(image)
            n += 1
    except BaseException:
        writer.close()
        tmp.unlink(missing_ok=True)
        raise
    writer.close()
    if n == 0:
        tmp.unlink(missing_ok=True)
        raise UserError(f"--out {path}: no frames to write")
    tmp.replace(path)
    return n


def goal_arrow(env: Any) -> tuple[Any, Any, Any]:
    """A task's goal as a green arrow. heading: on the ground from under the character, the
    commanded direction, one metre per m/s of commanded speed; strike: pointing down at the
    target's centre, red once it has been hit; throw: pointing down at the target on the floor,
    red once the ball has landed on it."""
    from mjxmimic.envs import step as step_lib

    if env.config.task.name == "strike":
        target = np.asarray(env.motion.goal[:3], np.float64)
        return target + [0.0, 0.0, 0.4], target, PUSH_RGBA if env.motion.goal[3] > 0 else GOAL_RGBA
    if env.config.task.name == "throw":
        goal = env.motion.goal
        target = np.array([goal[0], goal[1], 0.05])
        hit = goal[2] > 0 and goal[3] <= env.config.task.target_radius_m
        return target + [0.0, 0.0, 0.8], target, PUSH_RGBA if hit else GOAL_RGBA
    yaw, speed = step_lib.goal(env.spec, env.motion, np)
    tail = np.array([env.data.qpos[0], env.data.qpos[1], 0.05])
    return tail, tail + float(speed) * np.array([np.cos(yaw), np.sin(yaw), 0.0]), GOAL_RGBA


def goal_markers(env: Any, ball: bool = True) -> list[tuple[int, Any, Any, Any]]:
    """The throw task's target (a disc of the target radius on the floor) and, with `ball`, the ball
    (for a renderer whose model has no ball); none for other tasks."""
    import mujoco

    if env.config.task.name != "throw":
        return []
    radius = env.config.task.target_radius_m
    goal = env.motion.goal
    out = [(mujoco.mjtGeom.mjGEOM_CYLINDER, [goal[0], goal[1], 0.003], [radius, 0.003, 0.0], TARGET_RGBA)]
    if ball:
        from mjxmimic.core.scene import BALL_RGBA

        r = env.spec.ball.radius_m
        out.append((mujoco.mjtGeom.mjGEOM_SPHERE, env.data.qpos[-7:-4], [r, r, r], BALL_RGBA))
    return out


def render_policy(pf, out: Path, *, ghost: bool = True, clip: Any = None, start: float = 0.0,
                  seconds: float | None = None, width: int = 640, height: int = 480,
                  on_frame: Callable[[int], Any] | None = None,
                  push: tuple[float, float, float] | None = None,
                  skill_sequence: str | None = None,
                  switch_routes: Path | None = None, finish_cycle: str | None = None) -> dict[str, Any]:
    """Video of one episode of an exported policy (mjxmimic.portable.policy_file.PolicyFile) from
    the reference state at clip time `start`, one frame per control step, until the episode ends
    (fall, clip end, time limit) or `seconds` have passed. `push` (force N, episode time s, turn
    from the facing) pushes the pelvis for 0.2 s as the push test does, drawn as a red arrow.
    `skill_sequence` ("walk:4,run:4", a dataset policy) switches skills as `play` does, until a
    fall or the sequence's end, through the routes of `switch_routes` (skills.read_routes) if given,
    leaving the skills of `finish_cycle` (as `play --finish-cycle`: names, "auto" or "none", None
    for auto) only where their cycle ends."""
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.portable import skills

    character = pf.character()
    switches = {}
    if skill_sequence is not None:
        env = CpuEnv(playback_config(pf.config()), character, pf.clips(), pf.weights())
        skills.check_selectable(env)
        sequence = skills.parse_sequence(skill_sequence, [c.name for c in env.clips])
        skills.set_switch_options(env, switch_routes, finish_cycle)
        switches = skills.switch_steps(env, sequence)
        total = sum(skills.segment_steps(env, sequence))
        limit = total if seconds is None else min(total, max(1, round(seconds / env.control_dt)))
    else:
        env = CpuEnv(playback_config(pf.config()), character, clip if clip is not None else pf.clip())
        limit = env.max_steps if seconds is None else max(1, round(seconds / env.control_dt))
    if push is not None and push[1] >= limit * env.control_dt:
        raise UserError(f"--push at {push[1]:g} s: the video ends at {limit * env.control_dt:g} s")
    policy = pf.policy()
    throw = env.config.task.name == "throw"  # the camera backs off and follows the midpoint of the
    view = {"distance": 8.0, "elevation": -25.0} if throw else {}  # character and the target, metres away
    scene = Scene(pf.character_xml, character.nq, ghost, width, height, terrain=env.spec.terrain, **view)

    def focus():
        return 0.5 * (env.data.qpos[:2] + env.motion.goal[:2]) if throw else None
    info: dict[str, Any] = {"steps": 0, "fell": False, "reward": 0.0}

    def frames():
        obs = env.reset_at(start, clip=switches.get(0, 0))
        ref, _ = env.reference(env.time)
        yield scene.frame(env.data.qpos, ref, markers=goal_markers(env), focus=focus())
        for k in range(limit):
            if k > 0 and k in switches:
                obs = env.switch(switches[k])
            force, arrows = push_at_step(env, push, k)
            if env.config.task.name:
                arrows.append(goal_arrow(env))
            s = env.step(policy(obs), external_force=force)
            info["steps"] += 1
            info["reward"] += s.reward
            ref, _ = env.reference(env.time)
            yield scene.frame(env.data.qpos, ref, arrows, goal_markers(env), focus())
            if on_frame is not None:
                on_frame(info["steps"])
            if s.failed or (s.done and not switches):
                info["fell"] = s.failed
                break
            obs = s.obs

    try:
        n = write_frames(frames(), out, fps=1.0 / env.control_dt)
    finally:
        scene.close()
    return {"out": str(out), "frames": n, "fps": 1.0 / env.control_dt, "seconds": n * env.control_dt,
            "steps": info["steps"], "fell": info["fell"],
            "mean_reward": info["reward"] / max(info["steps"], 1), "ghost": ghost,
            "clip": env.clip.name, "start_time": float(start), "skill_sequence": skill_sequence,
            "gl": os.environ.get("MUJOCO_GL")}


def push_at_step(env: Any, push: tuple[float, float, float] | None, k: int) -> tuple[Any, list]:
    """(external force or None, arrows) of `push` (force N, episode time s, turn from the facing)
    at control step k: the push test's 0.2 s pelvis push, drawn as a red arrow while it acts."""
    from mjxmimic.core.kinematics import ROOT_BODY
    from mjxmimic.task import push_protocol

    if push is None:
        return None, []
    force, acting = push_protocol.scheduled(env.data.qpos, push, k, env.control_dt, env.model.nbody, np)
    if not acting:
        return force, []
    head = env.data.xipos[ROOT_BODY].copy()
    return force, [(head - force[ROOT_BODY, :3] * PUSH_ARROW_M_PER_N, head, PUSH_RGBA)]


def label(image: np.ndarray, text: str) -> np.ndarray:
    """`text` written at the image's top left (white on a dark box), through Pillow, which imageio
    brings; the image unchanged without it."""
    try:
        from PIL import Image, ImageDraw
    except ImportError:
        return image
    picture = Image.fromarray(image)
    draw = ImageDraw.Draw(picture)
    box = draw.textbbox((8, 8), text)
    draw.rectangle((box[0] - 4, box[1] - 4, box[2] + 4, box[3] + 4), fill=(20, 20, 20))
    draw.text((8, 8), text, fill=(255, 255, 255))
    return np.asarray(picture)


def render_composite(c: Any, out: Path, *, ghost: bool = True, seconds: float = 10.0, start: float = 0.0,
                     expert: str | None = None, push: tuple[float, float, float] | None = None, seed: int = 0,
                     width: int = 640, height: int = 480,
                     on_frame: Callable[[int], Any] | None = None) -> dict[str, Any]:
    """Video of a composite (mjxmimic.portable.composite.Composite) run as `mjxmimic play` runs it
    (the gate every step), the active expert's name and the time written on every frame, the
    ghost the active expert's reference, `push` drawn as a red arrow. Falls do not end it."""
    from mjxmimic.portable.composite import Player, timeline

    player = Player(c)
    env = player.env
    first = c.start_expert(expert)
    steps = max(1, round(seconds / env.control_dt))
    u = np.random.default_rng(seed).uniform(size=steps)
    scene = Scene(c.experts[0].character_xml, env.character.nq, ghost, width, height)
    names, info = c.names, {"steps": 0, "experts": []}

    def frames():
        player.reset(start, first)
        ref, _ = env.reference(env.time)
        yield label(scene.frame(env.data.qpos, ref), f"{names[first]}  0.0 s")
        for k in range(steps):
            force, arrows = push_at_step(env, push, k)
            s, d = player.step(u[k], force)
            info["steps"] += 1
            info["experts"].append(int(d.choice))
            ref, _ = env.reference(env.time)
            yield label(scene.frame(env.data.qpos, ref, arrows), f"{names[int(d.choice)]}  {(k + 1) * env.control_dt:.1f} s")
            if on_frame is not None:
                on_frame(info["steps"])
            if s.failed:
                break

    try:
        n = write_frames(frames(), out, fps=1.0 / env.control_dt)
    finally:
        scene.close()
    return {"out": str(out), "frames": n, "fps": 1.0 / env.control_dt, "seconds": n * env.control_dt,
            "steps": info["steps"], "timeline": timeline(names, info["experts"], env.control_dt),
            "ghost": ghost, "gl": os.environ.get("MUJOCO_GL")}


def render_clip(character, clip: Any, out: Path, *, seconds: float | None = None, fps: float = 30.0,
                width: int = 640, height: int = 480) -> dict[str, Any]:
    """Video of a clip's reference motion (kinematic, no physics): one cycle, or `seconds`."""
    from mjxmimic.motion import library as motion_lib

    lib = motion_lib.build_motion_lib([clip], character)
    duration = float(lib.duration[0])
    total = duration if seconds is None else float(seconds)
    n = max(2, int(np.floor(total * fps + 1e-6)) + 1)
    scene = Scene(Path(character.xml_path), character.nq, ghost=False, width=width, height=height)

    def frames():
        for k in range(n):
            qpos, _ = motion_lib.sample(lib, 0, np.float32(min(k / fps, total)), np)
            yield scene.frame(qpos)

    try:
        count = write_frames(frames(), out, fps=fps)
    finally:
        scene.close()
    return {"out": str(out), "frames": count, "fps": fps, "seconds": (count - 1) / fps, "clip": clip.name,
            "loop": bool(clip.loop), "gl": os.environ.get("MUJOCO_GL")}
