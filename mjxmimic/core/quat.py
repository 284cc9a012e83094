"""Quaternion and rotation math, (w, x, y, z), written once for numpy and jax.numpy.

Every function takes the array module as `xp` (numpy by default), so the training environment
(jax.numpy) and the CPU playback (numpy, no JAX) run the very same code. Arrays broadcast over
leading axes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

_EPS = 1e-9


def normalize(q: Any, xp: Any = np) -> Any:
    return q / xp.maximum(xp.linalg.norm(q, axis=-1, keepdims=True), _EPS)


def conj(q: Any, xp: Any = np) -> Any:
    return q * xp.asarray([1.0, -1.0, -1.0, -1.0], dtype=q.dtype)


def mul(a: Any, b: Any, xp: Any = np) -> Any:
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return xp.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def rotate(q: Any, v: Any, xp: Any = np) -> Any:
    """Rotate vector(s) v by unit quaternion(s) q."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * xp.cross(u, v)
    return v + w * t + xp.cross(u, t)


def to_matrix(q: Any, xp: Any = np) -> Any:
    """Rotation matrix (..., 3, 3) of unit quaternion(s)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return xp.stack([xp.stack(r, axis=-1) for r in rows], axis=-2)


def to_rotvec(q: Any, xp: Any = np) -> Any:
    """Axis x angle (the exponential-map log) of a unit quaternion, angle in [0, pi]."""
    q = q * xp.where(q[..., :1] < 0, -1.0, 1.0)  # the short way round
    s = xp.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * xp.arctan2(s, q[..., :1])
    scale = xp.where(s > _EPS, angle / xp.maximum(s, _EPS), 2.0)  # small angles: 2 * u
    return q[..., 1:] * scale


def from_rotvec(r: Any, xp: Any = np) -> Any:
    """Unit quaternion of an axis x angle vector (the exponential map)."""
    angle = xp.linalg.norm(r, axis=-1, keepdims=True)
    half = 0.5 * angle
    scale = xp.where(angle > _EPS, xp.sin(half) / xp.maximum(angle, _EPS), 0.5)
    return xp.concatenate([xp.cos(half), r * scale], axis=-1)


def angle(q: Any, xp: Any = np) -> Any:
    """Rotation angle of a unit quaternion, in [0, pi]."""
    s = xp.linalg.norm(q[..., 1:], axis=-1)
    return 2.0 * xp.arctan2(s, xp.abs(q[..., 0]))


def angle_between(a: Any, b: Any, xp: Any = np) -> Any:
    """Angle of the rotation that takes a to b."""
    return angle(mul(conj(a, xp), b, xp), xp)


def slerp(a: Any, b: Any, t: Any, xp: Any = np) -> Any:
    """Spherical interpolation from a (t=0) to b (t=1), the short way."""
    t = xp.asarray(t)[..., None] if xp.ndim(t) == xp.ndim(a) - 1 else t
    dot = xp.sum(a * b, axis=-1, keepdims=True)
    b = xp.where(dot < 0, -b, b)
    dot = xp.abs(dot)
    theta = xp.arccos(xp.clip(dot, -1.0, 1.0))
    sin_theta = xp.sin(theta)
    near = sin_theta < 1e-6
    safe = xp.where(near, 1.0, sin_theta)
    wa = xp.where(near, 1.0 - t, xp.sin((1.0 - t) * theta) / safe)
    wb = xp.where(near, t, xp.sin(t * theta) / safe)
    return normalize(wa * a + wb * b, xp)


def from_yaw(yaw: Any, xp: Any = np) -> Any:
    """Rotation about the world z axis (up)."""
    z = xp.zeros_like(yaw)
    return xp.stack([xp.cos(0.5 * yaw), z, z, xp.sin(0.5 * yaw)], axis=-1)


def heading(q: Any, xp: Any = np, kind: str = "forward") -> Any:
    """Yaw of a body's forward (x) axis projected onto the ground plane; or (`kind="twist"`) the
    twist about the vertical in q's swing-twist split. The forward axis of a body that faces the
    floor (the crawl's root) is nearly vertical, so its projection turns far with small tilts;
    the twist is ill-defined only for a body upside down."""
    if kind == "twist":
        return 2.0 * xp.arctan2(q[..., 3], q[..., 0])
    forward = rotate(q, xp.asarray([1.0, 0.0, 0.0], dtype=q.dtype), xp)
    return xp.arctan2(forward[..., 1], forward[..., 0])


def rotate_yaw(v: Any, yaw: Any, xp: Any = np) -> Any:
    """Rotate vectors (..., 3) about z by yaw (broadcast over leading axes)."""
    c, s = xp.cos(yaw)[..., None], xp.sin(yaw)[..., None]
    x, y = v[..., :1], v[..., 1:2]
    return xp.concatenate([c * x - s * y, s * x + c * y, v[..., 2:]], axis=-1)


def wrap_angle(a: Any, xp: Any = np) -> Any:
    return xp.arctan2(xp.sin(a), xp.cos(a))


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation that turns direction a into direction b (numpy only)."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    axis, cos = np.cross(a, b), float(a @ b)
    if cos < -1 + 1e-9:  # opposite: any perpendicular axis
        perp = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return np.concatenate([[0.0], perp / np.linalg.norm(perp)])
    return normalize(np.concatenate([[1.0 + cos], axis]))
