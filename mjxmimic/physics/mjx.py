"""MJX backends: impl='warp' (MuJoCo Warp, the GPU default) and impl='jax' (CPU and fallback).

Written for one world and vmapped by the env. Under warp, contacts live in one pool shared by all
worlds, so the data is made for `max_worlds` worlds at once (`naconmax`); resets merge with
`Data.where`, which knows which warp fields are per world. Kinematics for observations and
rewards are mjxmimic.core.forward_kinematics in jax.numpy on any backend: warp has no `com_vel`,
and MJX's general kinematics compiles several times slower.
"""

from __future__ import annotations

import contextlib
from importlib.metadata import version
from typing import Any

import jax
import jax.numpy as jnp
from mujoco import mjx

from mjxmimic.core.errors import UserError
from mjxmimic.core import forward_kinematics
from mjxmimic.core.kinematics import Kin
from mjxmimic.core.layout import Layout
from mjxmimic.core.scene import Scene
from mjxmimic.physics.backend import Substeps
from mjxmimic.physics.pd import Targets, pd_forces
from mjxmimic.physics.randomise import Scales, scaled_fields

BACKENDS = ("auto", "warp", "jax")


def warp_available() -> bool:
    """warp-lang importable and a CUDA GPU is JAX's default device."""
    try:
        import warp  # noqa: F401
    except ImportError:
        return False
    return jax.default_backend() == "gpu"


def resolve_backend(name: str) -> str:
    """'auto' -> 'warp' on a CUDA GPU with warp-lang installed, else 'jax'."""
    if name not in BACKENDS:
        raise UserError(f"config key 'physics.backend': {name!r} is not one of {', '.join(BACKENDS)}")
    if name == "auto":
        return "warp" if warp_available() else "jax"
    if name == "warp":
        try:
            import warp  # noqa: F401
        except ImportError:
            raise UserError("config key 'physics.backend': 'warp' needs warp-lang "
                            "(pip install -e \".[warp]\")") from None
    return name


@contextlib.contextmanager
def _quiet_solver_limits():
    """Warp prints a line per world and step when the solver or line search stops at its
    iteration limit, which a few iterations (the presets' 4) do by design; pool overflows stay
    loud. MJX copies MuJoCo Warp's options from the model that `mujoco_warp.put_model` builds, so
    this sets that model's documented `opt.warn_overflow` while MJX builds its own."""
    from mujoco.mjx.warp import mujoco_warp as mjw

    build = mjw.put_model
    quiet = int(mjw.OverflowType.ALL) & ~int(mjw.OverflowType.ITERATIONS) & ~int(mjw.OverflowType.LS_ITERATIONS)

    def put_model(*args: Any, **kwargs: Any) -> Any:
        model = build(*args, **kwargs)
        model.opt.warn_overflow = quiet
        return model

    mjw.put_model = put_model
    try:
        yield
    finally:
        mjw.put_model = build


class MjxPhysics:
    """One world of MJX physics (vmap it). `impl` is 'warp' or 'jax'."""

    xp = jnp

    def __init__(self, scene: Scene, layout: Layout, substeps: int, torque_limit: str, impl: str,
                 max_worlds: int = 1, contacts_per_world: int = 32, constraints_per_world: int = 160):
        self.name = impl
        self.simulator = f"mujoco-mjx {version('mujoco-mjx')} (impl {impl}, {jax.default_backend()})"
        self.scene = scene
        self.layout = layout
        self.substeps = substeps
        self.torque_limit = torque_limit
        self.dt = float(scene.model.opt.timestep)
        self.contact_adr = jnp.asarray(scene.contact_adr)
        if impl == "warp":
            import warp

            warp.config.log_level = warp.LOG_WARNING  # no start-up banner, no line per module loaded
            with _quiet_solver_limits():
                self.sys = mjx.put_model(scene.model, impl="warp")
            self._data0 = mjx.make_data(scene.model, impl="warp", naconmax=max_worlds * contacts_per_world,
                                        njmax=constraints_per_world)
        else:
            self.sys = mjx.put_model(scene.model, impl="jax")
            self._data0 = mjx.make_data(self.sys)
        self._tree = forward_kinematics.read_tree(scene.model, scene.nbody)
        self._nq, self._nv = scene.nq, scene.nv  # the character's
        self._extra_dofs = scene.model.nv - self._nv  # a ball's, after the character's

    def init(self, qpos: jax.Array, qvel: jax.Array) -> mjx.Data:
        return self._data0.replace(qpos=qpos, qvel=qvel)

    def where(self, done: jax.Array, fresh: mjx.Data, state: mjx.Data) -> mjx.Data:
        return state.where(done, fresh)

    def qpos_qvel(self, state: mjx.Data) -> tuple[jax.Array, jax.Array]:
        return state.qpos, state.qvel

    def model(self, scales: Scales | None) -> mjx.Model:
        """The model that an episode steps: the nominal one, or its randomised fields under
        `scales` (mjxmimic.physics.randomise). Under vmap those fields are batched, one per env,
        the rest shared: the per-env model that Brax's `in_axes` builds, made where it is used."""
        if scales is None:
            return self.sys
        return self.sys.replace(**scaled_fields(self.sys.body_mass, self.sys.body_inertia, self.sys.geom_friction,
                                                scales, jnp))

    def with_qpos_qvel(self, state: mjx.Data, qpos: jax.Array, qvel: jax.Array) -> mjx.Data:
        return state.replace(qpos=qpos, qvel=qvel)

    def step(self, state: mjx.Data, targets: Targets, external_force: Any = None,
             scales: Scales | None = None) -> Substeps:
        if external_force is not None:
            pad = self.scene.model.nbody - external_force.shape[0]  # a ball's body after the character's
            if pad:
                external_force = jnp.pad(external_force, ((0, pad), (0, 0)))
            state = state.replace(xfrc_applied=external_force)
        model = self.model(scales)

        def substep(data, _):
            forces = pd_forces(self.layout, data.qpos, data.qvel, targets, self.dt, jnp, self.torque_limit)
            if self._extra_dofs:
                forces = jnp.pad(forces, (0, self._extra_dofs))
            data = mjx.step(model, data.replace(qfrc_applied=forces))
            return data, data.sensordata[self.contact_adr] > 0

        data, contacts = jax.lax.scan(substep, state, None, length=self.substeps)
        if external_force is not None:
            data = data.replace(xfrc_applied=jnp.zeros_like(external_force))
        return Substeps(state=data, contacts=jnp.any(contacts, axis=0), diverged=jnp.zeros((), bool))

    def kinematics(self, qpos: jax.Array, qvel: jax.Array) -> Kin:
        return forward_kinematics.kinematics(self._tree, qpos[: self._nq], qvel[: self._nv], jnp)


