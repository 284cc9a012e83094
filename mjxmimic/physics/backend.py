"""The seam between the control step and a simulator.

A backend steps one character scene (`mjxmimic.core.scene.Scene`) for one environment: the MJX
backends are written for a single world and vmapped by the env; the MuJoCo C backend steps one
`MjData` in place. The control step (`mjxmimic.envs.step`) sees only this protocol, so the same
step runs on MJX-Warp, MJX-JAX and MuJoCo C.
"""

from __future__ import annotations

from typing import Any, NamedTuple, Protocol

from mjxmimic.core.kinematics import Kin
from mjxmimic.physics.pd import Targets
from mjxmimic.physics.randomise import Scales


class Substeps(NamedTuple):
    """What `Physics.step` returns."""

    state: Any  # the backend's state after the control step
    contacts: Any  # (S,) bool: the scene's floor-contact sensor i fired in some substep
    diverged: Any  # bool: the simulator itself flagged a diverged state (MuJoCo C's warnings)


class Physics(Protocol):
    name: str  # "warp", "jax" or "c"
    simulator: str  # what a result names as its simulator, with versions: push forces differ between them
    xp: Any  # numpy or jax.numpy: the array module that the step uses with this backend

    def init(self, qpos: Any, qvel: Any) -> Any:
        """A state at rest in (qpos, qvel), kinematics current."""

    def where(self, done: Any, fresh: Any, state: Any) -> Any:
        """`fresh` where done, else `state` (the auto-reset)."""

    def qpos_qvel(self, state: Any) -> tuple[Any, Any]:
        """The scene's whole qpos and qvel: the character's first, then a ball's if there is one."""

    def with_qpos_qvel(self, state: Any, qpos: Any, qvel: Any) -> Any:
        """The state with qpos and qvel replaced (the throw task carries its ball in the hand so);
        the next step recomputes everything else from them."""

    def step(self, state: Any, targets: Targets, external_force: Any = None, scales: Scales | None = None) -> Substeps:
        """One control step: `substeps` times the PD law towards `targets` and one physics step;
        `external_force` (nbody, 6) [force, torque] at body centres, held for the whole step (the
        character's bodies or the scene's); `scales` the episode's domain randomisation (None: the
        nominal model)."""

    def kinematics(self, qpos: Any, qvel: Any) -> Kin:
        """MuJoCo's kinematics of any pose of the character (the simulated body or the reference):
        its qpos and qvel, or the scene's with them as a prefix; the character's bodies only."""
