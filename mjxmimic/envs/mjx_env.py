"""The training environment: the control step (`mjxmimic.envs.step`) on an MJX backend, with
Brax's `Env` interface (unbatched; PPO vmaps it).

reset: a clip drawn by the library's weights, then the reference state at a random time (RSI).
step:  the control step; an ended episode restarts at once with a fresh draw (Brax's
       AutoResetWrapper would replay one cached start), merged with the backend's `where`.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from brax.envs.base import Env, State

from mjxmimic.core.character import Character, load_character, resolve_xml
from mjxmimic.core.compat import patch_all
from mjxmimic.core.config import Config, push_curriculum
from mjxmimic.envs import starts
from mjxmimic.envs import step as step_lib
from mjxmimic.motion import library as motion_lib
from mjxmimic.physics import randomise
from mjxmimic.physics.mjx import MjxPhysics, resolve_backend
from mjxmimic.task import goals, termination
from mjxmimic.task.events import PUSH_SCALE

patch_all()  # MJX's Newton solver can deadlock jaxlib 0.10's CPU LAPACK (see compat.py)

_MOTION_KEYS = step_lib.Motion._fields


class ImitationEnv(Env):
    """One character, a library of clips; unbatched (vmap it). `max_worlds` sizes warp's contact
    pool: the most envs that one device steps at once."""

    def __init__(self, config: Config, character: Character, clips: list[Any], weights: Any = None,
                 max_worlds: int | None = None):
        env = config.env
        self.config = config
        self.character = character
        self.clips = clips
        self.scene, self.spec = step_lib.build(config, character, clips, jnp, weights)
        if env.start_states_fraction > 0:
            from mjxmimic.envs import start_bank

            self.spec = self.spec._replace(start_bank=start_bank.build(config, character, self.scene, clips,
                                                                       weights, jnp))
        self.model = self.scene.model
        self.backend_name = resolve_backend(config.physics.backend)
        worlds = max_worlds or max(config.ppo.num_envs, config.run.eval_episodes)
        self.physics = MjxPhysics(self.scene, self.spec.layout, env.physics_hz // env.control_hz, env.torque_limit,
                                  self.backend_name, max_worlds=worlds,
                                  contacts_per_world=config.physics.contacts_per_world,
                                  constraints_per_world=config.physics.constraints_per_world)
        self.control_dt = self.spec.control_dt
        self.max_steps = self.spec.max_steps
        self.max_eval_horizon = starts.max_eval_horizon(self.spec)
        self.train_terminations = termination.training_list(env.pose_termination_m, env.early_termination,
                                                             config.terrain.kind != "none")
        self.eval_terminations = termination.evaluation_list(env.early_termination, config.terrain.kind != "none")
        self.clip_durations = self.spec.lib.duration
        self.eval_start_limits = starts.eval_start_limits(self.spec, jnp)
        self.clip_duration = float(self.spec.lib.duration[0])

    # Brax Env interface -------------------------------------------------------------------
    @property
    def observation_size(self) -> int:
        return self.spec.observation_size

    @property
    def action_size(self) -> int:
        return self.spec.action_size

    @property
    def backend(self) -> str:
        return f"mjx-{self.backend_name}"

    def draw_start(self, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        """(clip, time): a clip by weight, then a time by RSI (or the clip's start)."""
        k_clip, k_time = jax.random.split(key)
        clip = motion_lib.draw_clip(self.spec.lib, jax.random.uniform(k_clip), jnp)
        if not self.config.env.rsi:
            return clip, jnp.zeros((), jnp.float32)
        t = jax.random.uniform(k_time, (), maxval=1.0) * starts.start_time_range(self.spec, clip, jnp)
        return clip, t

    def reset(self, rng: jax.Array) -> State:
        rng, key = jax.random.split(rng)
        clip, t = self.draw_start(key)
        return self.reset_at(rng, t, clip)

    def reset_at(self, rng: jax.Array, t: jax.Array, clip: jax.Array | int = 0) -> State:
        """The reference state of `clip` at clip time t; the episode's event seed from `rng`."""
        rng, key = jax.random.split(rng)
        data, motion, obs = step_lib.reset(self.spec, self.physics, jnp.asarray(clip, jnp.int32), t,
                                           jax.random.uniform(key))
        zero = jnp.zeros(())
        info = {"rng": rng, "truncation": zero, "failed": zero, "clip_end": zero, **motion._asdict()}
        if push_curriculum(self.config.env):
            info[PUSH_SCALE] = jnp.ones(())
        metrics = {k: zero for k in self.metric_keys}
        return State(pipeline_state=data, obs=obs, reward=zero, done=zero, metrics=metrics, info=info)

    @property
    def metric_keys(self) -> list[str]:
        keys = ["reward", "reward/imitation", "fell", "lost_track", "physics/reset_nan", "error/pose",
                "error/end_effector"]
        keys += list(goals.METRICS[self.config.task.name])
        if self.config.reward.combine == "max":
            keys.append("reward/own_clip")
        if self.spec.terrain is not None:
            keys.append("terrain/x")
        if randomise.enabled(self.config.env):
            keys += ["randomise/friction", "randomise/mass"]
        return keys + [f"reward/{t.name}" for t in self.spec.rewards]

    def step(self, state: State, action: jax.Array) -> State:
        """One control step; an ended episode restarts at once with a fresh draw."""
        nxt = self.transition(state, action)
        rng, key = jax.random.split(nxt.info["rng"])
        fresh = self.reset(key)
        merged = self.select(nxt.done > 0, fresh, nxt)
        info = dict(nxt.info, rng=rng, **{k: merged.info[k] for k in _MOTION_KEYS})
        return nxt.replace(pipeline_state=merged.pipeline_state, obs=merged.obs, info=info)

    def select(self, pick: jax.Array, a: State, b: State) -> State:
        """`a` where pick, else `b` (physics through the backend's `where`); reward, done and
        metrics are b's."""
        info = jax.tree_util.tree_map(lambda x, y: jnp.where(pick, x, y), a.info, b.info)
        return b.replace(pipeline_state=self.physics.where(pick, a.pipeline_state, b.pipeline_state),
                         obs=jnp.where(pick, a.obs, b.obs), info=info)

    def transition(self, state: State, action: jax.Array, evaluation: bool = False,
                   external_force: jax.Array | None = None) -> State:
        """One control step without reset. Evaluation uses EVALUATION.md's terminations (none of
        the training-only ones) and also grades with the paper's reward. `external_force`
        (nbody, 6) is added to the events' (a push test's push)."""
        motion = step_lib.Motion(**{k: state.info[k] for k in _MOTION_KEYS})
        terms = self.eval_terminations if evaluation else self.train_terminations
        out = step_lib.control_step(self.spec, self.physics, state.pipeline_state, motion, action, terms,
                                    external_force, grade_paper=evaluation,
                                    push_scale=state.info.get(PUSH_SCALE, 1.0))
        f32 = jnp.float32
        info = dict(state.info, truncation=out.truncation.astype(f32), failed=out.failed.astype(f32),
                    clip_end=out.clip_end.astype(f32), **out.motion._asdict())
        return state.replace(pipeline_state=out.state, obs=out.obs, reward=out.reward,
                             done=out.done.astype(f32), metrics=out.metrics, info=info)

    def eval_horizon(self, t: Any, clip: Any = 0) -> Any:
        """Steps of the NR horizon from start time t (EVALUATION.md)."""
        return starts.eval_horizon(self.spec, clip, jnp.asarray(t), jnp)


def load_env_inputs(config: Config, run_dir: Any = None) -> tuple[Character, list[Any], list[float] | None]:
    """(character, clips, weights): clip.name is one clip, or a dataset of them (weights then);
    those that `run_dir` kept (mjxmimic.runs.folder.keep_clips) where it kept them."""
    from mjxmimic.motion import dataset
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.runs.folder import clip_source

    character = load_character(resolve_xml(config.character.xml))
    source = clip_source(config, run_dir)
    if dataset.is_dataset(source):
        data = dataset.load_dataset(source, character)
        return character, data.clips, data.weights
    return character, [load_clip_source(source, character)], None


def make_env(config: Config, max_worlds: int | None = None, run_dir: Any = None) -> ImitationEnv:
    """The env of `config`, with the clips that `run_dir` kept where it names a run that did."""
    character, clips, weights = load_env_inputs(config, run_dir)
    return ImitationEnv(config, character, clips, weights, max_worlds=max_worlds)
