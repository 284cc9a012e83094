"""The imitation environment: Brax's `Env` interface over MJX physics.

reset: reference state at a random clip time (RSI), drawn afresh on every reset.
step:  action -> PD targets -> `substeps` physics steps (PD law + mjx.step under lax.scan)
       -> observation, reward terms (sim and reference through the same MuJoCo kinematics),
       done. When an episode ends (fall, lost track of the reference if env.pose_termination_m is
       set, clip end, time limit, or a NaN/exploding state) the env resets itself with a new RSI
       draw: Brax's AutoResetWrapper would replay one cached start.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from brax.envs.base import Env, State
from mujoco import mjx

from mjxmimic.motion import library as motion_lib
from mjxmimic.core.compat import patch_all
from mjxmimic.core.character import Character, default_fall_contact, load_character, physics_model, resolve_xml
from mjxmimic.core.config import Config
from mjxmimic.physics.pd import action_to_targets, pd_forces
from mjxmimic.core.errors import UserError
from mjxmimic.core.kinematics import kin_from_data
from mjxmimic.core.layout import make_layout
from mjxmimic.task.observation import observation, observation_size
from mjxmimic.task.reward import KINDS, reward

patch_all()  # MJX's Newton solver can deadlock jaxlib 0.10's CPU LAPACK (see compat.py)


class ImitationEnv(Env):
    """One clip, one character; unbatched (vmap it)."""

    def __init__(self, config: Config, character: Character, clips: list[Any]):
        self.config = config
        self.character = character
        self.clips = clips
        self.model = physics_model(character, config.env.physics_hz, config.env.solver_iterations,
                                   config.env.ls_iterations)
        self.sys = mjx.put_model(self.model)
        self.layout = make_layout(character)
        self.motion = jax.tree.map(jnp.asarray, motion_lib.build_motion_lib(clips, character))
        self.substeps = config.env.physics_hz // config.env.control_hz
        self.control_dt = 1.0 / config.env.control_hz
        self.physics_dt = 1.0 / config.env.physics_hz
        self.max_steps = int(round(config.env.episode_seconds * config.env.control_hz))
        self.clip_duration = float(self.motion.duration[0])
        self.loop = bool(self.motion.loop[0])
        self.max_eval_horizon = self.max_steps if self.loop else int(np.ceil(self.clip_duration / self.control_dt))

        self._data0 = mjx.make_data(self.sys)
        spec = config.clip.fall_contact
        if spec == "auto":
            spec = default_fall_contact(clips[0].name)
        try:
            fall_bodies = np.array(character.fall_bodies(spec))
        except ValueError as err:
            raise UserError(f"config key 'clip.fall_contact': {err}") from None
        fall_geom = np.isin(self.model.geom_bodyid, fall_bodies)
        # Contact slots are fixed per model; one collision pass tells which geoms each slot holds
        # (jitted: run op by op it took 19 s of a 2-core CPU, compiled 5 s).
        probe = jax.jit(lambda d: mjx.collision(self.sys, mjx.kinematics(self.sys, d)))(self._data0)
        slots = np.asarray(probe._impl.contact.geom)
        self._fall_slots = jnp.asarray(fall_geom[slots].any(axis=1))
        self.fall_contact = spec
        self._metric_keys = ["reward", "fell", "lost_track"] + [f"reward/{t}" for t in KINDS[config.reward.kind]]
        self._metric_keys += ["error/pose", "error/end_effector"]

    # Brax Env interface -------------------------------------------------------------------
    @property
    def observation_size(self) -> int:
        return observation_size(self.model.nbody)

    @property
    def action_size(self) -> int:
        return self.character.action_size

    @property
    def backend(self) -> str:
        return "mjx"

    def reset(self, rng: jax.Array) -> State:
        rng, key = jax.random.split(rng)
        if self.config.env.rsi:
            last = self.clip_duration if self.loop else max(self.clip_duration - self.control_dt, 0.0)
            t = jax.random.uniform(key, (), minval=0.0, maxval=last)
        else:
            t = jnp.zeros(())
        return self.reset_at(rng, t)

    def reset_at(self, rng: jax.Array, t: jax.Array) -> State:
        """The reference state at clip time t."""
        t = jnp.asarray(t, dtype=jnp.float32)
        qpos, qvel = motion_lib.sample(self.motion, 0, t, jnp)
        data = self._kinematics(self._data0.replace(qpos=qpos, qvel=qvel))
        obs = observation(kin_from_data(data, jnp), motion_lib.phase(self.motion, 0, t, jnp), jnp)
        zero = jnp.zeros(())
        info = {"time": t, "steps": jnp.zeros((), jnp.int32), "rng": rng, "truncation": zero,
                "root_offset": jnp.zeros(2)}
        metrics = {k: zero for k in self._metric_keys}
        return State(pipeline_state=data, obs=obs, reward=zero, done=zero, metrics=metrics, info=info)

    def step(self, state: State, action: jax.Array) -> State:
        """One control step; an ended episode restarts at once with a fresh RSI draw."""
        nxt = self.transition(state, action)
        rng, key = jax.random.split(nxt.info["rng"])
        fresh = self.reset(key)
        done = nxt.done > 0
        pick = lambda a, b: jax.tree.map(lambda x, y: jnp.where(done, x, y), a, b)
        restart = ("time", "steps", "root_offset")
        info = dict(nxt.info, rng=rng, **pick({k: fresh.info[k] for k in restart}, {k: nxt.info[k] for k in restart}))
        return nxt.replace(pipeline_state=pick(fresh.pipeline_state, nxt.pipeline_state),
                           obs=jnp.where(done, fresh.obs, nxt.obs), info=info)

    # The physics and the grading ------------------------------------------------------------
    def transition(self, state: State, action: jax.Array, pose_termination: bool = True) -> State:
        """One control step without reset. Evaluation calls it directly, with
        pose_termination=False (a training-only early termination)."""
        cfg = self.config.env
        t = state.info["time"] + self.control_dt
        ref_qpos, ref_qvel = motion_lib.sample(self.motion, 0, t, jnp)  # the unshifted root
        targets = action_to_targets(self.layout, action, ref_qpos, cfg.action_mode, cfg.action_scale, jnp)

        def substep(data, _):
            forces = pd_forces(self.layout, data.qpos, data.qvel, targets, self.physics_dt, jnp, cfg.torque_limit)
            data = mjx.step(self.sys, data.replace(qfrc_applied=forces))
            contact = data._impl.contact
            fell = jnp.any(self._fall_slots & (contact.dist < 0.0))
            return data, fell

        data, fell = jax.lax.scan(substep, state.pipeline_state, None, length=self.substeps)
        fell = jnp.any(fell) & cfg.early_termination
        data = self._kinematics(data)
        offset = state.info["root_offset"]
        if self.config.reward.sync_root_position:
            offset = motion_lib.sync_root_offset(self.motion, 0, state.info["time"], t, offset,
                                                 data.qpos[0:2], ref_qpos[0:2], jnp)
        ref_qpos = motion_lib.shift_root(ref_qpos, offset, jnp)
        ref = self._kinematics(self._data0.replace(qpos=ref_qpos, qvel=ref_qvel))
        sim_kin, ref_kin = kin_from_data(data, jnp), kin_from_data(ref, jnp)
        r, metrics = reward(self.layout, sim_kin, ref_kin, self.config.reward.kind, jnp)

        finite = jnp.all(jnp.isfinite(data.qpos)) & jnp.all(jnp.isfinite(data.qvel))
        bad = ~finite | jnp.any(jnp.abs(data.qvel) > cfg.max_joint_velocity)
        lost = jnp.zeros((), bool)
        if pose_termination and cfg.pose_termination_m > 0:
            gap = jnp.linalg.norm(sim_kin.xipos[1:] - ref_kin.xipos[1:], axis=-1)
            lost = jnp.max(gap) > cfg.pose_termination_m
        steps = state.info["steps"] + 1
        timeout = steps >= self.max_steps
        clip_end = (not self.loop) & (t >= self.clip_duration - 1e-4)
        failed = fell | bad | lost
        done = failed | timeout | clip_end
        r = jnp.where(failed, 0.0, r)
        obs = observation(sim_kin, motion_lib.phase(self.motion, 0, t, jnp), jnp)
        obs = jnp.where(bad, 0.0, jnp.nan_to_num(obs))
        metrics = dict(metrics, reward=r, fell=fell.astype(jnp.float32), lost_track=lost.astype(jnp.float32))
        metrics = {k: jnp.where(bad, 0.0, jnp.nan_to_num(v)) if k.startswith("error") else v
                   for k, v in metrics.items()}
        info = dict(state.info, time=t, steps=steps, root_offset=offset,
                    truncation=(timeout & ~failed & ~clip_end).astype(jnp.float32))
        return state.replace(pipeline_state=data, obs=obs, reward=r, done=done.astype(jnp.float32),
                             metrics=metrics, info=info)

    def _kinematics(self, data: mjx.Data) -> mjx.Data:
        data = mjx.kinematics(self.sys, data)
        data = mjx.com_pos(self.sys, data)
        return mjx.com_vel(self.sys, data)

    def eval_horizon(self, t: Any) -> Any:
        """Steps of the NR horizon from start time t (EVALUATION.md)."""
        if self.loop:
            return jnp.full(jnp.shape(t), self.max_steps, jnp.int32)
        return jnp.ceil((self.clip_duration - jnp.asarray(t)) / self.control_dt - 1e-4).astype(jnp.int32)


def load_env_inputs(config: Config) -> tuple[Character, list[Any]]:
    from mjxmimic.motion.clip import load_clip_source

    character = load_character(resolve_xml(config.character.xml))
    return character, [load_clip_source(config.clip.name, character)]


def make_env(config: Config) -> ImitationEnv:
    character, clips = load_env_inputs(config)
    return ImitationEnv(config, character, clips)
