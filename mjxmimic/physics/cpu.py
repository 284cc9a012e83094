"""MuJoCo C backend: one `MjData` stepped in place with numpy, for CPU playback, the viewer and
the evaluation of exported policies. No JAX on this path."""

from __future__ import annotations

import copy
from typing import Any

import mujoco
import numpy as np

from mjxmimic.core.kinematics import Kin, kin_from_data
from mjxmimic.core.layout import Layout
from mjxmimic.core.scene import Scene
from mjxmimic.physics.backend import Substeps
from mjxmimic.physics.pd import Targets, pd_forces
from mjxmimic.physics.randomise import Scales, scaled_fields

_DIVERGED = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL,
             mujoco.mjtWarning.mjWARN_BADQPOS)


class CpuPhysics:
    """MuJoCo C physics of one character (the state is this object's own `MjData`)."""

    name = "c"
    simulator = f"mujoco {mujoco.__version__} (CPU, mj_step)"
    xp = np

    def __init__(self, scene: Scene, layout: Layout, substeps: int, torque_limit: str):
        self.scene = scene
        self.model = scene.model
        self.layout = layout
        self.substeps = substeps
        self.torque_limit = torque_limit
        self.dt = float(scene.model.opt.timestep)
        self.data = mujoco.MjData(self.model)
        self._scratch = mujoco.MjData(self.model)
        self._scaled = copy.copy(self.model)  # the stepped model under domain randomisation

    def stepped_model(self, scales: Scales | None) -> mujoco.MjModel:
        """The model that an episode steps: the nominal one, or a copy with its randomised fields
        under `scales` (mjxmimic.physics.randomise); kinematics keep the nominal one, as on MJX."""
        if scales is None:
            return self.model
        fields = scaled_fields(self.model.body_mass, self.model.body_inertia, self.model.geom_friction,
                               Scales(float(scales.friction), np.asarray(scales.mass, np.float64)), np)
        for name, value in fields.items():
            getattr(self._scaled, name)[:] = value
        return self._scaled

    def init(self, qpos: Any, qvel: Any) -> mujoco.MjData:
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = qpos
        self.data.qvel[:] = qvel
        mujoco.mj_forward(self.model, self.data)
        return self.data

    def where(self, done: Any, fresh: Any, state: Any) -> Any:
        return fresh if done else state

    def qpos_qvel(self, state: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        return state.qpos.copy(), state.qvel.copy()

    def with_qpos_qvel(self, state: mujoco.MjData, qpos: Any, qvel: Any) -> mujoco.MjData:
        state.qpos[:] = qpos
        state.qvel[:] = qvel
        return state

    def _warnings(self, data: mujoco.MjData) -> int:
        return sum(int(data.warning[w].number) for w in _DIVERGED)

    def step(self, state: mujoco.MjData, targets: Targets, external_force: Any = None,
             scales: Scales | None = None) -> Substeps:
        data = state
        model = self.stepped_model(scales)
        warnings0 = self._warnings(data)
        if external_force is not None:
            data.xfrc_applied[: len(external_force)] = external_force
        contacts = np.zeros(len(self.scene.contact_adr), bool)
        nv = self.layout.v_perm.shape[0]  # the character's; a ball's dofs get no force
        for _ in range(self.substeps):
            data.qfrc_applied[:nv] = pd_forces(self.layout, data.qpos, data.qvel, targets, self.dt, np,
                                               self.torque_limit)
            mujoco.mj_step(model, data)
            contacts |= data.sensordata[self.scene.contact_adr] > 0
        data.xfrc_applied[:] = 0.0
        return Substeps(state=data, contacts=contacts, diverged=self._warnings(data) > warnings0)

    def kinematics(self, qpos: Any, qvel: Any) -> Kin:
        d, scene = self._scratch, self.scene
        nq, nv, nbody = scene.nq, scene.nv, scene.nbody
        d.qpos[:nq] = qpos[:nq]
        d.qvel[:nv] = qvel[:nv]
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)
        mujoco.mj_comVel(self.model, d)
        k = kin_from_data(d, np)
        return Kin(qpos=k.qpos[:nq], qvel=k.qvel[:nv], xipos=k.xipos[:nbody], xmat=k.xmat[:nbody],
                   angvel=k.angvel[:nbody], linvel=k.linvel[:nbody], com=k.com)
