"""The composite policy's gate (DeepMimic section 7), written once for numpy and jax.numpy: which
expert drives the next control step, and at which time of its clip.

The composite env is the ordinary control step (`mjxmimic.envs.step`) on a motion library that
holds every expert's clip, clip id = expert index; `Motion.clip` is the active expert and
`Motion.time` its clip time, so the PD targets (residual actions) and the reference follow the
active expert alone. Before every control step (DeepMimic evaluates the values every step):

1. Each expert e gets its own observation of the current state: the observation terms with the
   phase of *its* clip at its candidate time (a single-clip expert's skill one-hot is [1]). The
   candidate time is the active expert's current time for the active expert (it goes on), and for
   any other expert its entry time: the time whose reference pose is nearest the character's (body
   positions, axes and velocities relative to the root in the heading frame, over a grid of
   control-step times), so that a locomotion expert takes over in step with the legs, and a getup
   where its clip looks like the fallen character rather than always lying flat at its start (its
   value was learnt from every clip time, by RSI). Measured on the CPU with GPU-trained walk and
   getups, nearest-pose entry for the getups raised the recovery rate (experiments/composite/).
2. Each expert's value network grades its observation: V_e.
3. Softmax over V_e / temperature among the allowed experts, sampled with one uniform number u
   (inverse CDF, so that the numpy player and MJX pick alike from the same u); temperature 0 is
   the arg max. A non-looping expert whose clip has just ended is not allowed (no immediate
   repeat); it may be chosen again once another expert has run a step.
4. A change of expert sets the clip and its candidate time, and moves the reference root under
   the character (the root offset); the chosen expert's policy acts on its observation.

Tracking for the recovery rule (mjxmimic.task.recovery) is graded against the active expert's
reference turned and moved to the character (as a task's reward is), so that a character walking
again after a getup in a new direction counts as tracking the walk.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from mjxmimic.core.kinematics import ROOT_BODY, Kin
from mjxmimic.envs import entry as entry_lib
from mjxmimic.envs import skill_switch
from mjxmimic.envs import step as step_lib
from mjxmimic.motion import library as motion_lib
from mjxmimic.physics.backend import Physics
from mjxmimic.task import goals
from mjxmimic.task import observation as obs_terms
from mjxmimic.task import reward as reward_terms


class Gate(NamedTuple):
    """Per-composite constants, arrays in the step's xp (from `make_gate`)."""

    loop: Any  # (E,) bool
    entry: entry_lib.Entry  # each expert's candidate entry times (a grid of control steps) and poses there
    temperature: float  # static
    stand_height: float  # mean root height of the looping experts' references (m)


class Decision(NamedTuple):
    choice: Any  # int: the expert for the coming step
    times: Any  # (E,) candidate clip times
    obs: Any  # (E, obs) each expert's observation
    values: Any  # (E,) the value estimates
    probabilities: Any  # (E,) the gate's distribution
    root_height: Any  # root body centre-of-mass height now (m)
    pose_error: Any  # mean joint angle (rad) from the active expert's reference, aligned to the character


def make_gate(spec: step_lib.Spec, kinematics: Callable[[Any, Any], Kin], temperature: float) -> Gate:
    """The gate's constants (numpy) for the experts of `spec.lib`; `kinematics` a numpy one (the
    CPU physics'). Convert with `to_xp` for MJX."""
    grid, heights = entry_lib.pose_grid(spec.lib, spec.control_dt, kinematics)
    loop = np.asarray(spec.lib.loop, bool)
    standing = heights[loop[:, None] & grid.valid]
    if standing.size == 0:
        raise ValueError("a composite needs at least one looping (locomotion) expert")
    return Gate(loop=loop, entry=grid, temperature=float(temperature), stand_height=float(np.mean(standing)))


def to_xp(gate: Gate, xp: Any) -> Gate:
    return gate._replace(loop=xp.asarray(gate.loop), entry=entry_lib.to_xp(gate.entry, xp))


def probabilities(values: Any, temperature: float, allowed: Any, xp: Any) -> Any:
    """softmax(values / temperature) over the allowed experts (0 elsewhere); temperature 0: the
    allowed arg max (the first of ties)."""
    values = xp.asarray(values, xp.float32)
    if temperature <= 0:
        masked = xp.where(allowed, values, -xp.inf)
        return (xp.arange(values.shape[-1]) == xp.argmax(masked)).astype(xp.float32)
    z = xp.where(allowed, values / temperature, -xp.inf)
    z = z - xp.max(z)
    p = xp.where(allowed, xp.exp(z), 0.0)
    return p / xp.sum(p)


def sample(p: Any, u: Any, xp: Any) -> Any:
    """The expert that uniform u in [0, 1) picks from distribution p (inverse CDF); never one of
    probability 0."""
    cdf = xp.cumsum(p)
    index = xp.sum((cdf <= u * cdf[-1]).astype(xp.int32))
    last = xp.max(xp.where(p > 0, xp.arange(p.shape[0]), 0))  # rounding: stay among the possible
    return xp.minimum(index, last)


def expert_observations(spec: step_lib.Spec, k: Kin, times: Any, xp: Any) -> Any:
    """(E, obs): every expert's observation of the state `k`, each with its own clip's phase at its
    candidate time; each expert's reference turned and moved onto the character, as its
    tracking error takes it (so reference_root reads no offset)."""
    one = xp.ones(1, xp.float32)
    rows = [obs_terms.observe(spec.observations, k, motion_lib.phase(spec.lib, e, times[e], xp), xp, one, k.qpos,
                              spec.config.env.observation_heading)
            for e in range(len(spec.lib.duration))]
    return xp.stack(rows)


def tracking_error(spec: step_lib.Spec, physics: Physics, sim: Kin, qpos: Any, motion: step_lib.Motion,
                   xp: Any) -> Any:
    """Mean joint angle (rad) from the active expert's reference at its time, turned and moved to
    the character."""
    ref_qpos, ref_qvel = motion_lib.sample(spec.lib, motion.clip, motion.time, xp)
    ref = physics.kinematics(*goals.align_reference(ref_qpos, ref_qvel, qpos, xp))
    return reward_terms.tracking_errors(spec.layout, sim, ref, xp)["error/pose"]


def decide(spec: step_lib.Spec, gate: Gate, physics: Physics, qpos: Any, qvel: Any, motion: step_lib.Motion,
           values_of: Callable[[Any], Any], u: Any) -> Decision:
    """The gate's decision for the coming step (module docstring). values_of((E, obs)) -> (E,)."""
    xp = physics.xp
    k = physics.kinematics(qpos, qvel)
    count = len(spec.lib.duration)
    active = xp.arange(count) == motion.clip
    times = xp.where(active, motion.time, entry_lib.nearest_times(gate.entry, k, xp)).astype(xp.float32)  # (E,)
    obs = expert_observations(spec, k, times, xp)
    values = xp.asarray(values_of(obs), xp.float32)
    allowed = ~(active & motion_lib.ended(spec.lib, motion.clip, motion.time, xp))  # no immediate repeat
    p = probabilities(values, gate.temperature, allowed, xp)
    return Decision(choice=sample(p, u, xp), times=times, obs=obs, values=values, probabilities=p,
                    root_height=k.xipos[ROOT_BODY, 2], pose_error=tracking_error(spec, physics, k, qpos, motion, xp))


def switch(spec: step_lib.Spec, motion: step_lib.Motion, decision: Decision, qpos: Any, xp: Any) -> step_lib.Motion:
    """The motion state with the chosen expert active: unchanged when it already was; else its
    clip at its entry time, the reference root moved under the character."""
    choice = decision.choice
    same = choice == motion.clip
    t = decision.times[choice]
    offset = xp.where(same, motion.root_offset, skill_switch.root_under(spec, choice, t, qpos, xp).astype(motion.root_offset.dtype))
    return motion._replace(clip=xp.where(same, motion.clip, choice).astype(xp.asarray(motion.clip).dtype),
                           time=xp.where(same, motion.time, t).astype(xp.float32), root_offset=offset)
