"""Motion clips: DeepMimic's JSON format in, a validated `Clip` (numpy, z-up, unit quaternions) out.

A clip file (DEEPMIMIC.md, "Motion clip format") is y-up with x forward and z to the right; each
frame is [duration, root position (3), root quaternion (w, x, y, z), then each joint in the
character's clip order: a quaternion for a ball joint, an angle for a hinge]. Here it becomes a
(frames, nq) array in the MuJoCo model's qpos layout, z-up: positions and quaternion vector parts
go through (x, y, z) -> (x, -z, y), hinge angles stay as they are (the MJCF's hinges are about -y,
DeepMimic's local z). Quaternions are normalised and made hemisphere-consistent frame to frame.

Clips are found by name (see `resolve_clip`): the project's clips/ folder, then the user's folders
(--clips-dir or MJXMIMIC_CLIPS), then pybullet's copy of the DeepMimic motions if it is installed.

numpy and mujoco only: no JAX here (CPU playback and `mjxmimic clips` use this module).
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.errors import UserError

if TYPE_CHECKING:
    from mjxmimic.core.character import Character

LOOP_MODES = ("wrap", "none")
PREFIX = "humanoid3d_"  # DeepMimic's file-name prefix for the humanoid's clips
SUFFIXES = (".txt", ".json")
ENV_VAR = "MJXMIMIC_CLIPS"
PROJECT_CLIPS = Path(__file__).resolve().parent / "clips"
_ZERO_NORM = 1e-8


class ClipError(UserError):
    """A clip that cannot be found or read; the message names the file (and frame, 0-based)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Clip:
    """One motion clip on the host, in the character's qpos layout (z-up, unit quaternions)."""

    name: str
    path: Path | None
    loop: bool  # True for "wrap" (cyclic), False for "none"
    durations: np.ndarray  # (F,) seconds from each frame to the next; the last is ignored
    qpos: np.ndarray  # (F, nq)
    max_quat_norm_error: float = 0.0  # largest | |q| - 1 | in the file, before normalising

    @property
    def num_frames(self) -> int:
        return int(self.qpos.shape[0])

    @property
    def loop_mode(self) -> str:
        return "wrap" if self.loop else "none"

    @property
    def frame_times(self) -> np.ndarray:
        """(F,) start time of each frame: 0, then the running sum of durations."""
        return np.concatenate([[0.0], np.cumsum(self.durations[:-1])])

    @property
    def duration(self) -> float:
        """Clip length in seconds: the sum of all durations but the last."""
        return float(np.sum(self.durations[:-1]))

    @property
    def fps(self) -> float:
        return (self.num_frames - 1) / self.duration

    @property
    def root_pos(self) -> np.ndarray:
        return self.qpos[:, 0:3]

    @property
    def root_quat(self) -> np.ndarray:
        return self.qpos[:, 3:7]

    @property
    def root_displacement(self) -> np.ndarray:
        """(3,) root position at the last frame minus the first (a cyclic clip's carry-over)."""
        return self.qpos[-1, 0:3] - self.qpos[0, 0:3]

    @property
    def root_travel(self) -> float:
        """Horizontal (xy) distance in metres from the first root position to the last."""
        return float(np.linalg.norm(self.root_displacement[:2]))

    @property
    def mean_speed(self) -> float:
        """root_travel / duration, metres per second."""
        return self.root_travel / self.duration

    @property
    def root_path(self) -> float:
        """Horizontal length in metres of the root's path over the frames: a clip that turns (a
        figure of eight, a walk there and back) travels far along it and little from start to end."""
        return float(np.linalg.norm(np.diff(self.root_pos[:, :2], axis=0), axis=1).sum())

    @property
    def heading_change(self) -> float:
        """Root heading (yaw about z) at the last frame minus the first, radians in (-pi, pi]."""
        first, last = (float(quat.heading(q)) for q in (self.qpos[0, 3:7], self.qpos[-1, 3:7]))
        return float(math.remainder(last - first, 2 * math.pi))


# ---------------------------------------------------------------------------------------- loading


def _quat_slots(character: Character) -> list[tuple[str, int]]:
    """(name, qpos address) of every quaternion: the root's, then each ball joint's."""
    return [("root", 3)] + [(j.name, j.qpos_adr) for j in character.joints if j.qpos_width == 4]


def _y_up_to_z_up(v: np.ndarray) -> np.ndarray:
    """(..., 3) vectors (x, y, z) y-up -> (x, -z, y) z-up."""
    return np.stack([v[..., 0], -v[..., 2], v[..., 1]], axis=-1)


def _z_up_to_y_up(v: np.ndarray) -> np.ndarray:
    """The inverse map: (x, y, z) z-up -> (x, z, -y) y-up."""
    return np.stack([v[..., 0], v[..., 2], -v[..., 1]], axis=-1)


def _clip_name(path: Path, prefix: str = PREFIX) -> str:
    stem = path.stem
    return stem[len(prefix):] if prefix and stem.startswith(prefix) and len(stem) > len(prefix) else stem


def _is_number(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _parse_constant(name: str) -> float:
    # NaN, Infinity and -Infinity literals: let them through as floats so that the finiteness
    # check below reports them with their frame index.
    return float(name)


def load_clip(path: str | Path, character: Character) -> Clip:
    """Read and validate a DeepMimic clip file for `character`; raises ClipError."""
    path = Path(path)
    if not path.exists():
        raise ClipError(f"{path}: clip file not found")
    if not path.is_file():
        raise ClipError(f"{path}: is not a file")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise ClipError(f"{path}: not JSON (not UTF-8 text: {err.reason} at byte {err.start})") from None
    except OSError as err:
        raise ClipError(f"{path}: cannot read: {err.strerror}") from None
    try:
        data = json.loads(text, parse_constant=_parse_constant)
    except json.JSONDecodeError as err:
        raise ClipError(f"{path}: not JSON (line {err.lineno}, column {err.colno}: {err.msg})") from None
    return clip_from_json(data, character, path=path, name=_clip_name(path, character.clip_prefix))


def _fits_hint(path: Path | None, character: Character) -> str:
    """For a clip of another shipped character (by its file name): which, and the option to pass."""
    from mjxmimic.core.character import character_for_clip

    other = character_for_clip(path, default=None) if path is not None else None
    return "" if other in (None, character.xml_path.stem) else f" (a clip of {other}: --character {other})"


def clip_from_json(data: object, character: Character, path: Path | None = None, name: str = "clip") -> Clip:
    """Validate a parsed DeepMimic clip (the JSON value) and convert it; raises ClipError."""
    where = str(path) if path is not None else name

    def fail(msg: str, frame: int | None = None) -> ClipError:
        at = f" frame {frame} (0-based):" if frame is not None else ""
        return ClipError(f"{where}:{at} {msg}")

    if not isinstance(data, dict):
        raise fail(f"the top level must be a JSON object with \"Loop\" and \"Frames\", got {_kind(data)}")
    for key in ("Loop", "Frames"):
        if key not in data:
            raise fail(f"missing \"{key}\" (a DeepMimic clip has \"Loop\" and \"Frames\")")
    loop = data["Loop"]
    if loop not in LOOP_MODES:
        raise fail(f"unknown Loop value {loop!r} (allowed: \"wrap\", \"none\")")
    frames = data["Frames"]
    if not isinstance(frames, list):
        raise fail(f"\"Frames\" must be a list of frames, got {_kind(frames)}")
    if len(frames) < 2:
        raise fail(f"a clip needs at least two frames, got {len(frames)}")

    width = character.clip_width
    for f, frame in enumerate(frames):
        if not isinstance(frame, list):
            raise fail(f"a frame must be a list of numbers, got {_kind(frame)}", f)
        for i, v in enumerate(frame):
            if not _is_number(v):
                raise fail(f"value {i} is not a number: {json.dumps(v)[:40]}", f)
        if len(frame) != width:
            raise fail(f"expected {width} values per frame for character {character.xml_path.name}, "
                       f"got {len(frame)}{_fits_hint(path, character)}", f)
    raw = np.asarray(frames, dtype=np.float64)
    bad = ~np.isfinite(raw)
    if bad.any():
        f, i = (int(k) for k in np.argwhere(bad)[0])
        raise fail(f"value {i} is {raw[f, i]} (NaN or infinite)", f)
    durations = raw[:, 0].copy()
    nonpos = np.flatnonzero(durations[:-1] <= 0)
    if nonpos.size:
        f = int(nonpos[0])
        raise fail(f"duration must be positive (all frames but the last), got {durations[f]:g}", f)

    qpos = _frames_to_qpos(raw[:, 1:], character)
    max_err = 0.0
    for jname, adr in _quat_slots(character):
        q = qpos[:, adr:adr + 4]
        norms = np.linalg.norm(q, axis=1)
        zero = np.flatnonzero(norms < _ZERO_NORM)
        if zero.size:
            raise fail(f"the {jname} quaternion has zero norm", int(zero[0]))
        max_err = max(max_err, float(np.max(np.abs(norms - 1.0))))
        q = q / norms[:, None]
        qpos[:, adr:adr + 4] = _hemisphere_consistent(q)

    for arr in (durations, qpos):
        arr.setflags(write=False)
    return Clip(name=name, path=path, loop=loop == "wrap", durations=durations, qpos=qpos,
                max_quat_norm_error=max_err)


def _kind(v: object) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "a boolean"
    if _is_number(v):
        return "a number"
    return {str: "a string", list: "a list", dict: "an object"}.get(type(v), type(v).__name__)


def _frames_to_qpos(values: np.ndarray, character: Character) -> np.ndarray:
    """(F, clip_width - 1) numbers after the duration, y-up -> (F, nq) qpos, z-up (not normalised)."""
    qpos = np.zeros((values.shape[0], character.nq), dtype=np.float64)
    qpos[:, 0:3] = _y_up_to_z_up(values[:, 0:3])
    qpos[:, 3] = values[:, 3]
    qpos[:, 4:7] = _y_up_to_z_up(values[:, 4:7])
    col = 7
    for joint in character.joints:
        adr = joint.qpos_adr
        if joint.qpos_width == 4:
            qpos[:, adr] = values[:, col]
            qpos[:, adr + 1:adr + 4] = _y_up_to_z_up(values[:, col + 1:col + 4])
        else:
            qpos[:, adr] = values[:, col]
        col += joint.qpos_width
    return qpos


def _qpos_to_frames(qpos: np.ndarray, character: Character) -> np.ndarray:
    """The inverse of `_frames_to_qpos`: (F, nq) z-up -> (F, clip_width - 1) y-up."""
    out = np.zeros((qpos.shape[0], character.clip_width - 1), dtype=np.float64)
    out[:, 0:3] = _z_up_to_y_up(qpos[:, 0:3])
    out[:, 3] = qpos[:, 3]
    out[:, 4:7] = _z_up_to_y_up(qpos[:, 4:7])
    col = 7
    for joint in character.joints:
        adr = joint.qpos_adr
        if joint.qpos_width == 4:
            out[:, col] = qpos[:, adr]
            out[:, col + 1:col + 4] = _z_up_to_y_up(qpos[:, adr + 1:adr + 4])
        else:
            out[:, col] = qpos[:, adr]
        col += joint.qpos_width
    return out


def _hemisphere_consistent(q: np.ndarray) -> np.ndarray:
    """Flip q[f] to -q[f] where needed so that dot(q[f], q[f-1]) >= 0 for every f."""
    dots = np.einsum("fi,fi->f", q[1:], q[:-1])
    signs = np.cumprod(np.where(dots < 0, -1.0, 1.0))
    out = q.copy()
    out[1:] *= signs[:, None]
    return out


def format_clip(clip: Clip, character: Character, comment: str | None = None, decimals: int = 10) -> str:
    """The DeepMimic JSON text of `clip` (y-up), one frame per line; `load_clip` reads it back."""
    values = np.concatenate([clip.durations[:, None], _qpos_to_frames(np.asarray(clip.qpos), character)],
                            axis=1)
    values = np.round(values, decimals) + 0.0  # + 0.0 turns -0.0 into 0.0
    lines = ["{"]
    if comment:
        lines.append(f"\"Comment\": {json.dumps(comment)},")
    lines.append(f"\"Loop\": \"{clip.loop_mode}\",")
    lines.append("\"Frames\":")
    lines.append("[")
    rows = ["[" + ", ".join(f"{v:.{decimals}f}" for v in row) + "]" for row in values]
    lines.append(",\n".join(rows))
    lines.append("]")
    lines.append("}")
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------------- kinematics


def lowest_points(character: Character, qpos: np.ndarray,
                  bodies: tuple[int, ...] | None = None) -> np.ndarray:
    """(F,) height of the lowest point of the character's geoms at each pose (mujoco kinematics).

    `bodies` limits it to the geoms of those body ids (e.g. character.body_sets["feet"] for the
    soles); by default every geom not on the world body (the floor) counts.
    """
    model = character.model
    data = mujoco.MjData(model)
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] != 0
             and (bodies is None or int(model.geom_bodyid[g]) in bodies)]
    out = np.empty(qpos.shape[0])
    for f, q in enumerate(np.asarray(qpos)):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        out[f] = min(_geom_bottom(model, data, g) for g in geoms)
    return out


def _geom_bottom(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> float:
    """World z of a geom's lowest point."""
    z = float(data.geom_xpos[g, 2])
    up = data.geom_xmat[g].reshape(3, 3)[2]  # world z of each local axis
    size = model.geom_size[g]
    gtype = int(model.geom_type[g])
    if gtype == mujoco.mjtGeom.mjGEOM_SPHERE:
        return z - size[0]
    if gtype == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return z - abs(up[2]) * size[1] - size[0]
    if gtype == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return z - abs(up[2]) * size[1] - size[0] * math.sqrt(max(0.0, 1 - up[2] ** 2))
    if gtype == mujoco.mjtGeom.mjGEOM_BOX:
        return z - float(np.sum(np.abs(up) * size))
    if gtype == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return z - float(np.sqrt(np.sum((up * size) ** 2)))
    return z - float(model.geom_rbound[g])


# ------------------------------------------------------------------------------ name resolution


def _pybullet_motions_dir() -> Path | None:
    """pybullet_data/data/motions if pybullet's data package is installed (not imported)."""
    try:
        spec = importlib.util.find_spec("pybullet_data")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations))) / "data" / "motions"


def search_folders(user_dir: str | Path | None = None) -> list[tuple[str, Path]]:
    """(source label, folder) in lookup order: project clips/, user folder(s), pybullet."""
    folders: list[tuple[str, Path]] = [("project", PROJECT_CLIPS)]
    if user_dir is not None:
        folders.append(("--clips-dir", Path(user_dir).expanduser()))
    else:
        for part in os.environ.get(ENV_VAR, "").split(os.pathsep):
            if part.strip():
                folders.append((ENV_VAR, Path(part.strip()).expanduser()))
    pybullet = _pybullet_motions_dir()
    if pybullet is not None:
        folders.append(("pybullet", pybullet))
    return folders


def _candidates(folder: Path, name: str, prefix: str) -> list[Path]:
    base = Path(name)
    out = []
    if base.suffix in SUFFIXES:
        out.append(folder / base)
    out += [folder / f"{name}.txt", folder / f"{name}.json",
            folder / base.parent / f"{prefix}{base.name}.txt"]
    return out


def resolve_clip(source: str | Path, user_dir: str | Path | None = None, prefix: str = PREFIX) -> Path:
    """A clip's file from a PATH or a NAME; raises ClipError listing where it looked.

    An existing file is used as it is. Otherwise NAME is looked up in the project's clips/ folder,
    then the user folder (`user_dir`, else each folder in $MJXMIMIC_CLIPS, separated by os.pathsep),
    then pybullet's pybullet_data/data/motions; in each folder NAME.txt, NAME.json or
    PREFIX + NAME.txt, the character's clip prefix (so "walk" finds humanoid3d_walk.txt, and "trot"
    dog3d_trot.txt for the dog).
    """
    source = str(source)
    if not source:
        raise ClipError("empty clip name")
    direct = Path(source).expanduser()
    if direct.is_file():
        return direct
    if direct.exists():
        raise ClipError(f"{source}: is a directory, not a clip file")
    folders = search_folders(user_dir)
    for _, folder in folders:
        for cand in _candidates(folder, source, prefix):
            if cand.is_file():
                return cand
    if "/" in source:  # a path: the names tried in the folders would only repeat it
        raise ClipError(f"{source}: no such clip file")
    looked = "; ".join(f"{folder} ({label}{'' if folder.is_dir() else ', missing'})"
                       for label, folder in folders)
    if not any(label == "pybullet" for label, _ in folders):
        looked += "; pybullet_data (not installed)"
    names = ", ".join(repr(n) for n in (f"{source}.txt", f"{source}.json", f"{prefix}{source}.txt"))
    raise ClipError(f"unknown clip {source!r}: no such file, and none of {names} in: {looked}")


def clip_label(source: str) -> str:
    """A clip NAME as it is, a PATH as its file stem: the clip part of run names."""
    return Path(source).stem if ("/" in source or source.endswith(SUFFIXES)) else source


def list_clips(user_dir: str | Path | None = None, prefix: str = PREFIX) -> list[tuple[str, Path, str]]:
    """(name, path, source label) of every clip that `resolve_clip` can find by name.

    Names drop the character's clip prefix (humanoid3d_, dog3d_); where a name occurs twice the
    first source wins, as in `resolve_clip`.
    """
    found: dict[str, tuple[str, Path, str]] = {}
    for label, folder in search_folders(user_dir):
        if not folder.is_dir():
            continue
        names = sorted({_clip_name(p, prefix) for p in folder.iterdir() if p.is_file() and p.suffix in SUFFIXES})
        for name in names:
            if name in found:
                continue
            for cand in _candidates(folder, name, prefix):
                if cand.is_file():
                    found[name] = (name, cand, label)
                    break
    return sorted(found.values(), key=lambda t: t[0])


def load_clip_source(source: str | Path, character: Character, user_dir: str | Path | None = None) -> Clip:
    """resolve_clip, then load_clip."""
    return load_clip(resolve_clip(source, user_dir, character.clip_prefix), character)
