"""Termination terms: each a pure function of one control step's outcome that says whether the
episode failed there. The evaluation list ends episodes as EVALUATION.md says (falls, and states
the simulator lost); training may add `pose_deviation`, MimicKit's remedy for a stay-up optimum
(a body more than `env.pose_termination_m` from the reference). Time limits and the end of a
non-looping clip are not failures and are handled by the step itself.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

from mjxmimic.core.kinematics import ROOT_BODY, Kin


class Outcome(NamedTuple):
    """What a termination term may read."""

    sim: Kin
    ref: Kin
    contacts: Any  # (S,) bool, floor-contact sensors that fired during the step
    fall_mask: Any  # (S,) bool, the sensors that count as a fall for this env's clip
    reference_geoms: Any  # per sensor: body, centre offset, radius (scene.sensor_geoms); None: plain rule
    diverged: Any  # bool, the simulator's own divergence flag
    max_joint_velocity: float
    pose_termination_m: float
    pit_z: Any = None  # on a terrain: the root below this height fell into a gap or off the beam
    pose_from_root: bool = False  # env.pose_termination_frame=root


# a reference geom whose bounding sphere comes this close to the floor counts as touching it
REFERENCE_CONTACT_M = 0.05


def fall(o: Outcome, xp: Any) -> Any:
    """A fall-contact body touched the floor (DeepMimic's early termination), unless the reference
    has that geom on the floor too (env.fall_ignores_reference_contacts)."""
    falls = o.contacts & o.fall_mask
    if o.reference_geoms is not None:
        falls = falls & ~reference_contacts(o.ref, *o.reference_geoms, xp)
    return xp.any(falls)


def reference_contacts(ref: Kin, body: Any, offset: Any, radius: Any, xp: Any) -> Any:
    """(S,) bool: for each contact sensor (its geom's body, centre offset and bounding radius),
    whether the reference pose has that geom on the floor."""
    centre = ref.xipos[body] + xp.einsum("sij,sj->si", ref.xmat[body], offset)
    return centre[:, 2] - radius < REFERENCE_CONTACT_M


def bad_state(o: Outcome, xp: Any) -> Any:
    """NaN, an exploding joint velocity, or a state the simulator flagged: reset and count it."""
    finite = xp.all(xp.isfinite(o.sim.qpos)) & xp.all(xp.isfinite(o.sim.qvel))
    return ~finite | xp.any(xp.abs(o.sim.qvel) > o.max_joint_velocity) | o.diverged


def pose_deviation(o: Outcome, xp: Any) -> Any:
    """Some body's centre is more than env.pose_termination_m from the reference's (training only;
    with `pose_from_root`, from the reference's moved sideways onto the character's root)."""
    ref = o.ref.xipos[1:]
    if o.pose_from_root:
        ref = ref + (o.sim.xipos[ROOT_BODY] - o.ref.xipos[ROOT_BODY]) * xp.asarray([1.0, 1.0, 0.0])
    gap = xp.sqrt(xp.sum((o.sim.xipos[1:] - ref) ** 2, axis=-1))
    return xp.max(gap) > o.pose_termination_m


def pit(o: Outcome, xp: Any) -> Any:
    """On a terrain: the root is below every walkable surface (mjxmimic.core.terrain), so the
    character fell into a gap or off the beam."""
    return o.sim.xipos[ROOT_BODY, 2] < o.pit_z


TERMS: dict[str, Callable[[Outcome, Any], Any]] = {"fall": fall, "bad_state": bad_state,
                                                   "pose_deviation": pose_deviation, "pit": pit}
EVALUATION = ("fall", "bad_state")


def training_list(pose_termination_m: float, early_termination: bool = True, terrain: bool = False) -> tuple[str, ...]:
    names = ("fall",) if early_termination else ()
    names += ("bad_state",)
    if pose_termination_m > 0:
        names += ("pose_deviation",)
    return names + (("pit",) if terrain else ())


def evaluation_list(early_termination: bool = True, terrain: bool = False) -> tuple[str, ...]:
    """Falls and lost states; on a terrain also a fall into a gap (whatever env.early_termination
    says: the character cannot get out)."""
    return (EVALUATION if early_termination else ("bad_state",)) + (("pit",) if terrain else ())
