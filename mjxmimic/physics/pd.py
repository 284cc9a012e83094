"""Actions to PD targets, and the PD law: one implementation for training and CPU playback.

Action: 28 numbers in [-1, 1] in clip joint order, an exponential map per ball joint and an angle
per hinge. "absolute" targets (DeepMimic): a ball joint's map spans +-pi * scale, a hinge spans
its range. "residual" targets: the reference pose at the step's end, turned by the action * scale.

PD law (a documented equivalent of stable PD, Tan et al. 2011): damping -kd qd is each joint's
MuJoCo damping, which the Euler integrator applies implicitly ((M + dt Kd) qacc = ...), as stable
PD does; the proportional term uses the pose one step ahead, Kp (q_target - (q + dt qd)), also as
stable PD does. The implicit stiffness term (dt^2 Kp in the matrix) is left out; the physics-rate
study shows the result is stable.

Torque limit ("total", DeepMimic's): the joint's whole PD torque, Kp (...) - Kd qd, is clamped to
the torque-norm limit. Since MuJoCo applies -Kd qd itself, the force handed to it is the clamped
total plus Kd qd; unclamped, that is just the proportional term. The earlier law
("proportional") clamped the proportional term alone, so damping was never limited and capped
every driven joint's speed at limit / Kd (3 rad/s for a knee): too slow for a backflip's take-off.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.layout import Layout


class Targets(NamedTuple):
    ball: Any  # (B, 4) target quaternions, local to the parent
    hinge: Any  # (H,) target angles


def action_to_targets(
    layout: Layout, action: Any, ref_qpos: Any, mode: str, scale: float, xp: Any = np
) -> Targets:
    a = xp.clip(action, -1.0, 1.0)
    rotvec = a[layout.action_ball]
    hinge_a = a[layout.action_hinge]
    if mode == "residual":
        ref_ball = ref_qpos[layout.q_quat[1:]]
        ball = quat.mul(ref_ball, quat.from_rotvec(rotvec * scale, xp), xp)
        hinge = ref_qpos[layout.q_scalar[3:]] + scale * hinge_a
    else:
        ball = quat.from_rotvec(rotvec * (np.pi * scale), xp)
        mid = 0.5 * (layout.hinge_low + layout.hinge_high)
        half = 0.5 * (layout.hinge_high - layout.hinge_low)
        hinge = mid + half * scale * hinge_a
    return Targets(ball=ball, hinge=hinge)


def _clamp_norm(tau: Any, limit: Any, xp: Any) -> Any:
    norm = xp.linalg.norm(tau, axis=-1, keepdims=True)
    return tau * xp.minimum(1.0, limit[:, None] / xp.maximum(norm, 1e-9))


def pd_forces(layout: Layout, qpos: Any, qvel: Any, targets: Targets, dt: float, xp: Any = np,
              torque_limit: str = "total") -> Any:
    """Generalised forces (nv,) for qfrc_applied (MuJoCo adds the damping); zero on the root."""
    q_ball = qpos[layout.q_quat[1:]]
    w_ball = qvel[layout.v_ang[1:]]
    ahead = quat.mul(q_ball, quat.from_rotvec(w_ball * dt, xp), xp)
    err_ball = quat.to_rotvec(quat.mul(quat.conj(ahead, xp), targets.ball, xp), xp)
    q_h = qpos[layout.q_scalar[3:]]
    w_h = qvel[layout.v_scalar[3:]]
    tau_ball = layout.ball_kp[:, None] * err_ball
    tau_h = layout.hinge_kp * (targets.hinge - (q_h + dt * w_h))
    if torque_limit == "total":
        damp_ball, damp_h = layout.ball_kd[:, None] * w_ball, layout.hinge_kd * w_h
        tau_ball = _clamp_norm(tau_ball - damp_ball, layout.ball_limit, xp) + damp_ball
        tau_h = xp.clip(tau_h - damp_h, -layout.hinge_limit, layout.hinge_limit) + damp_h
    else:
        tau_ball = _clamp_norm(tau_ball, layout.ball_limit, xp)
        tau_h = xp.clip(tau_h, -layout.hinge_limit, layout.hinge_limit)

    zeros3 = xp.zeros(3, dtype=tau_h.dtype)
    scalars = xp.concatenate([zeros3, tau_h])
    angular = xp.concatenate([zeros3, xp.reshape(tau_ball, (-1,))])
    return xp.concatenate([scalars, angular])[layout.v_perm]
