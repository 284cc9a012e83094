"""BVH motion capture files: the skeleton, the frames, and forward kinematics on the host.

BVH's own conventions: a joint's rotation channels compose in the order they are listed (each
about the joint's local axis, degrees), the rest pose is all channels zero, and a joint's OFFSET
is its position in its parent's frame. Errors name the file and line.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.errors import UserError

AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}
CHANNELS = {f"{a}{kind}" for a in "XYZ" for kind in ("position", "rotation")}


class BvhError(UserError):
    """A BVH file that cannot be read; the message names the file and line."""


@dataclasses.dataclass(frozen=True)
class Joint:
    name: str
    parent: int  # index into Bvh.joints, -1 for the root
    offset: np.ndarray  # (3,) position in the parent's frame, file units
    channels: tuple[str, ...]  # e.g. ("Xposition", ..., "Zrotation", "Yrotation", "Xrotation")
    column: int  # first column of its channels in a frame row
    end_site: np.ndarray | None  # (3,) offset of the End Site, if it has one


@dataclasses.dataclass(frozen=True)
class Bvh:
    path: Path
    joints: tuple[Joint, ...]  # parents before children
    frame_time: float  # seconds
    values: np.ndarray  # (F, columns) channel values, as in the file

    @property
    def num_frames(self) -> int:
        return int(self.values.shape[0])

    @property
    def names(self) -> list[str]:
        return [joint.name for joint in self.joints]

    def index(self, name: str) -> int:
        for i, joint in enumerate(self.joints):
            if joint.name == name:
                return i
        raise KeyError(name)

    def local_rotations(self) -> np.ndarray:
        """(F, J, 4) each joint's rotation in its parent's frame (wxyz)."""
        out = np.zeros((self.num_frames, len(self.joints), 4))
        out[..., 0] = 1.0
        for j, joint in enumerate(self.joints):
            for k, channel in enumerate(joint.channels):
                if channel.endswith("rotation"):
                    half = np.radians(self.values[:, joint.column + k]) / 2
                    step = np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * AXES[channel[0]]], axis=1)
                    out[:, j] = quat.mul(out[:, j], step)
        return out

    def forward_kinematics(self) -> tuple[np.ndarray, np.ndarray]:
        """(F, J, 3) world positions (file units) and (F, J, 4) world rotations of every joint."""
        local = self.local_rotations()
        frames, count = self.num_frames, len(self.joints)
        pos, rot = np.zeros((frames, count, 3)), np.zeros((frames, count, 4))
        for j, joint in enumerate(self.joints):
            offset = np.broadcast_to(joint.offset, (frames, 3)).copy()
            for k, channel in enumerate(joint.channels):
                if channel.endswith("position"):  # replaces the OFFSET's component
                    offset[:, "XYZ".index(channel[0])] = self.values[:, joint.column + k]
            if joint.parent < 0:
                pos[:, j], rot[:, j] = offset, local[:, j]
            else:
                pos[:, j] = pos[:, joint.parent] + quat.rotate(rot[:, joint.parent], offset)
                rot[:, j] = quat.mul(rot[:, joint.parent], local[:, j])
        return pos, rot

    def rest_positions(self) -> np.ndarray:
        """(J, 3) joint positions in the rest pose (all channels zero), file units."""
        out = np.zeros((len(self.joints), 3))
        for j, joint in enumerate(self.joints):
            out[j] = joint.offset + (out[joint.parent] if joint.parent >= 0 else 0.0)
        return out


class _Tokens:
    """The file's whitespace-separated words with their line numbers."""

    def __init__(self, path: Path, text: str):
        self.path = path
        self.words = [(word, n) for n, line in enumerate(text.splitlines(), 1) for word in line.split()]
        self.i = 0

    def fail(self, msg: str, line: int | None = None) -> BvhError:
        if line is None:
            line = self.words[min(self.i, len(self.words) - 1)][1] if self.words else 1
        return BvhError(f"{self.path}:{line}: {msg}")

    def peek(self) -> str | None:
        return self.words[self.i][0] if self.i < len(self.words) else None

    def take(self, what: str) -> str:
        if self.i >= len(self.words):
            raise self.fail(f"the file ends where {what} was expected")
        word = self.words[self.i][0]
        self.i += 1
        return word

    def expect(self, word: str) -> None:
        got = self.take(repr(word))
        if got != word:
            self.i -= 1
            raise self.fail(f"expected {word!r}, found {got!r}")

    def number(self, what: str) -> float:
        word = self.take(what)
        try:
            value = float(word)
        except ValueError:
            self.i -= 1
            raise self.fail(f"{what}: {word!r} is not a number") from None
        if not math.isfinite(value):
            self.i -= 1
            raise self.fail(f"{what}: {word!r} is not finite")
        return value


def _joint(tokens: _Tokens, name: str, parent: int, joints: list[Joint], column: int) -> int:
    """Reads one joint's block (after its name) and its children; returns the next free column."""
    tokens.expect("{")
    tokens.expect("OFFSET")
    offset = np.array([tokens.number(f"{name}'s OFFSET") for _ in range(3)])
    tokens.expect("CHANNELS")
    count = tokens.number(f"{name}'s channel count")
    if count != int(count) or not 0 <= count <= 6:
        raise tokens.fail(f"{name}: a channel count of {count:g} (expected 0 to 6)")
    channels = tuple(tokens.take(f"{name}'s channels") for _ in range(int(count)))
    for channel in channels:
        if channel not in CHANNELS:
            raise tokens.fail(f"{name}: unknown channel {channel!r}")
    if any(j.name == name for j in joints):
        raise tokens.fail(f"joint {name!r} is defined twice")
    index = len(joints)
    joints.append(Joint(name, parent, offset, channels, column, None))
    column += len(channels)
    while True:
        word = tokens.take(f"JOINT, End Site or '}}' in {name}")
        if word == "}":
            return column
        if word == "JOINT":
            column = _joint(tokens, tokens.take("a joint name"), index, joints, column)
        elif word == "End":
            tokens.expect("Site")
            tokens.expect("{")
            tokens.expect("OFFSET")
            site = np.array([tokens.number(f"{name}'s End Site OFFSET") for _ in range(3)])
            tokens.expect("}")
            joints[index] = dataclasses.replace(joints[index], end_site=site)
        else:
            tokens.i -= 1
            raise tokens.fail(f"in joint {name}: expected JOINT, End Site or '}}', found {word!r}")


def parse_bvh(text: str, path: Path) -> Bvh:
    tokens = _Tokens(path, text)
    if tokens.peek() is None:
        raise BvhError(f"{path}: the file is empty")
    tokens.expect("HIERARCHY")
    tokens.expect("ROOT")
    joints: list[Joint] = []
    columns = _joint(tokens, tokens.take("the root's name"), -1, joints, 0)
    if tokens.peek() == "ROOT":
        raise tokens.fail("more than one ROOT: only one skeleton per file is supported")
    tokens.expect("MOTION")
    tokens.expect("Frames:")
    count = tokens.number("the frame count")
    if count != int(count) or count < 1:
        raise tokens.fail(f"a frame count of {count:g} (expected a positive whole number)")
    tokens.expect("Frame")
    tokens.expect("Time:")
    frame_time = tokens.number("the frame time")
    if frame_time <= 0:
        raise tokens.fail(f"a frame time of {frame_time:g} s (expected a positive number)")
    rate = round(1 / frame_time)
    if rate > 0 and abs(1 / frame_time - rate) < 1e-4 * rate:  # files write 1/120 s as .0083333
        frame_time = 1 / rate
    start = tokens.i
    words = [w for w, _ in tokens.words[start:]]
    expected = int(count) * columns
    if len(words) != expected:
        last_line = tokens.words[-1][1]
        raise BvhError(f"{path}:{last_line}: {len(words)} values after the header, expected {int(count)} frames "
                       f"x {columns} channels = {expected}")
    try:
        values = np.array(words, dtype=np.float64).reshape(int(count), columns)
    except ValueError:
        bad = next(i for i, w in enumerate(words) if not _is_float(w))
        tokens.i = start + bad
        raise tokens.fail(f"frame {bad // columns}: {words[bad]!r} is not a number") from None
    if not np.all(np.isfinite(values)):
        bad = int(np.argmax(~np.isfinite(values).reshape(-1)))
        tokens.i = start + bad
        raise tokens.fail(f"frame {bad // columns}: a value that is not finite")
    return Bvh(path, tuple(joints), frame_time, values)


def _is_float(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def load_bvh(path: str | Path) -> Bvh:
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise BvhError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as err:
        raise BvhError(f"{path}: cannot read it ({getattr(err, 'strerror', None) or err})") from None
    return parse_bvh(text, path)
