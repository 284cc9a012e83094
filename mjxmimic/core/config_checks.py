"""The checks of a config (mjxmimic.core.config): every value that would fail later, or mean
nothing, is refused when the config is made, in one line that names the key."""

from __future__ import annotations

import dataclasses
import math

from mjxmimic.core.config import (LR_SCHEDULES, MATMUL_PRECISIONS, REFERENCE_VELOCITIES, SEED_MAX, STD_MODES, TASKS,
                                  TERRAINS, Config, has_pushes)
from mjxmimic.core.errors import UserError


def _scale_range_ok(factors: tuple[float, ...], zero_ok: bool = False) -> bool:
    if len(factors) != 2:
        return False
    lo, hi = factors
    return (lo >= 0 if zero_ok else lo > 0) and lo <= hi


def _non_finite_key(config: Config) -> str | None:
    """The first key holding nan or inf (alone or in a tuple): no setting means either, and they
    would pass every bound below (nan compares false both ways) and fail during training."""
    for section in dataclasses.fields(config):
        values = getattr(config, section.name)
        for field in dataclasses.fields(values):
            value = getattr(values, field.name)
            numbers = value if isinstance(value, tuple) else (value,)
            if any(isinstance(v, float) and not math.isfinite(v) for v in numbers):
                return f"{section.name}.{field.name}"
    return None


def validate(config: Config) -> None:
    """Reject values that would fail later, naming the key."""
    bad = _non_finite_key(config)
    if bad is not None:
        raise UserError(f"config key {bad!r}: must be a finite number")
    env, ppo, run = config.env, config.ppo, config.run
    checks = [
        (env.control_hz > 0, "env.control_hz", "must be positive"),
        (env.physics_hz > 0 and env.physics_hz % max(env.control_hz, 1) == 0, "env.physics_hz",
         f"must be a positive multiple of env.control_hz ({env.control_hz})"),
        (env.solver_iterations >= 1, "env.solver_iterations", "must be at least 1"),
        (env.ls_iterations >= 1, "env.ls_iterations", "must be at least 1"),
        (env.episode_seconds > 0, "env.episode_seconds", "must be positive"),
        (env.max_joint_velocity > 0, "env.max_joint_velocity", "must be positive"),
        (env.pose_termination_m >= 0, "env.pose_termination_m", "must be >= 0 (0 = off)"),
        (env.pose_termination_frame in ("world", "root"), "env.pose_termination_frame", "must be 'world' or 'root'"),
        (env.action_mode in ("absolute", "residual"), "env.action_mode", "must be 'absolute' or 'residual'"),
        (env.torque_limit in ("total", "proportional"), "env.torque_limit", "must be 'total' or 'proportional'"),
        (env.observation_heading in ("forward", "twist"), "env.observation_heading",
         "must be 'forward' or 'twist'"),
        (env.action_scale > 0, "env.action_scale", "must be positive"),
        (env.push_force_n >= 0, "env.push_force_n", "must be >= 0"),
        (not has_pushes(env) or env.push_force_n > 0 or env.push_force_max_n > 0, "env.events",
         "push needs a force: set env.push_force_n (or env.push_force_max_n) above 0"),
        (env.push_duration_s > 0, "env.push_duration_s", "must be positive"),
        (env.push_force_max_n == 0 or env.push_force_max_n >= env.push_force_n, "env.push_force_max_n",
         f"must be 0 (a fixed force) or at least env.push_force_n ({env.push_force_n})"),
        (env.push_interval_jitter_s >= 0, "env.push_interval_jitter_s", "must be >= 0"),
        (env.push_directions in ("any", "table6"), "env.push_directions", "must be 'any' or 'table6'"),
        (env.push_sideways_scale > 0, "env.push_sideways_scale", "must be positive"),
        (env.push_sideways_scale == 1.0 or env.push_directions == "table6", "env.push_sideways_scale",
         "scales the sideways pushes of env.push_directions=table6: set that too"),
        (env.push_ramp_samples >= 0, "env.push_ramp_samples", "must be >= 0 (0: no curriculum)"),
        (env.push_ramp_samples == 0 or has_pushes(env), "env.push_ramp_samples",
         "ramps pushes: set env.events=push too"),
        (env.push_start_samples >= 0, "env.push_start_samples", "must be >= 0 (0: pushes from the start)"),
        (env.push_start_samples == 0 or has_pushes(env), "env.push_start_samples",
         "delays pushes: set env.events=push too"),
        (env.push_stop_samples >= 0, "env.push_stop_samples", "must be >= 0 (0: pushes to the end)"),
        (env.push_stop_samples == 0 or has_pushes(env), "env.push_stop_samples",
         "stops pushes: set env.events=push too"),
        (env.push_stop_samples == 0 or env.push_stop_samples > env.push_start_samples + env.push_ramp_samples,
         "env.push_stop_samples", "must come after env.push_start_samples + env.push_ramp_samples (the full pushes)"),
        (0 < env.push_episode_share <= 1, "env.push_episode_share", "must be in (0, 1]"),
        (env.push_episode_share == 1 or has_pushes(env), "env.push_episode_share",
         "picks pushed episodes: set env.events=push too"),
        (env.push_settle_s >= 0, "env.push_settle_s", "must be >= 0 (seconds; 0 = off)"),
        (env.push_settle_s == 0 or has_pushes(env), "env.push_settle_s", "follows pushes: set env.events=push too"),
        (env.reset_noise_rad >= 0, "env.reset_noise_rad", "must be >= 0 (radians; 0 = off)"),
        (_scale_range_ok(env.reset_velocity_range, zero_ok=True), "env.reset_velocity_range",
         "must be two factors lo,hi with 0 <= lo <= hi (finite)"),
        (0 <= env.start_states_fraction <= 1, "env.start_states_fraction", "must be in [0, 1]"),
        (env.start_states_fraction == 0 or env.start_states != "", "env.start_states_fraction",
         "needs env.start_states (a .npz of qpos and qvel)"),
        (env.skill_switch_s >= 0, "env.skill_switch_s", "must be >= 0 (seconds; 0 = off)"),
        (env.skill_switch_s == 0 or "skill" in env.observations.split(","), "env.skill_switch_s",
         "needs the skill observation (env.observations=...,skill)"),
        (env.skill_switch_entry in ("phase", "nearest"), "env.skill_switch_entry", "must be 'phase' or 'nearest'"),
        (env.skill_switch_settle_s >= 0, "env.skill_switch_settle_s", "must be >= 0 (seconds; 0 = off)"),
        (env.push_interval_s > env.push_duration_s + env.push_interval_jitter_s, "env.push_interval_s",
         "must be longer than env.push_duration_s + env.push_interval_jitter_s"),
        (_scale_range_ok(env.friction_range), "env.friction_range", "must be two factors lo,hi with 0 < lo <= hi (finite)"),
        (_scale_range_ok(env.mass_range), "env.mass_range", "must be two factors lo,hi with 0 < lo <= hi (finite)"),
        (config.reward.kind in ("released", "paper"), "reward.kind", "must be 'released' or 'paper'"),
        (config.reward.combine in ("own", "max"), "reward.combine", "must be 'own' or 'max'"),
        (config.task.name in ("",) + TASKS, "task.name", f"must be '' (none) or one of {', '.join(TASKS)}"),
        (0 <= config.task.target_min_m <= config.task.target_max_m, "task.target_min_m",
         "must be >= 0 and at most task.target_max_m"),
        (config.task.target_radius_m > 0, "task.target_radius_m", "must be positive"),
        (config.task.imitation_weight >= 0 and config.task.task_weight >= 0, "task.imitation_weight",
         "task weights must be >= 0"),
        (config.task.speed >= 0, "task.speed", "must be >= 0 (0: the clip's own speed)"),
        (config.task.resample_s > 0, "task.resample_s", "must be positive"),
        (config.task.release_s > 0, "task.release_s", "must be positive (a clip time in s)"),
        (config.task.throw_shape > 0, "task.throw_shape", "must be positive"),
        (config.terrain.kind in ("none",) + TERRAINS, "terrain.kind",
         f"must be 'none' or one of {', '.join(TERRAINS)}"),
        (0 <= config.terrain.difficulty <= 1, "terrain.difficulty", "must be in [0, 1]"),
        (config.terrain.lanes >= 1, "terrain.lanes", "must be at least 1"),
        (0 <= config.terrain.seed <= SEED_MAX, "terrain.seed", f"must be in 0..{SEED_MAX}"),
        (config.terrain.length_m > 0 and config.terrain.depth_m > 0 and config.terrain.lane_width_m > 0,
         "terrain.length_m", "length, lane width and depth must be positive"),
        (len(config.terrain.heightmap_shape) == 2 and min(config.terrain.heightmap_shape) >= 1,
         "terrain.heightmap_shape", "must be two positive sizes, rows,cols (e.g. 8,8)"),
        (config.terrain.heightmap_spacing_m > 0, "terrain.heightmap_spacing_m", "must be positive"),
        (config.clip.velocity in REFERENCE_VELOCITIES, "clip.velocity", "must be 'forward' or 'central'"),
        (config.physics.backend in ("auto", "warp", "jax"), "physics.backend", "must be 'auto', 'warp' or 'jax'"),
        (config.physics.contacts_per_world >= 1, "physics.contacts_per_world", "must be at least 1"),
        (config.physics.constraints_per_world >= 1, "physics.constraints_per_world", "must be at least 1"),
        (ppo.num_envs >= 1, "ppo.num_envs", "must be at least 1"),
        (ppo.unroll_length >= 1, "ppo.unroll_length", "must be at least 1"),
        (ppo.num_minibatches >= 1 and (ppo.num_envs % ppo.num_minibatches == 0), "ppo.num_minibatches",
         f"must divide ppo.num_envs ({ppo.num_envs})"),
        (ppo.num_epochs >= 1, "ppo.num_epochs", "must be at least 1"),
        (ppo.learning_rate > 0, "ppo.learning_rate", "must be positive"),
        (ppo.std_mode in STD_MODES, "ppo.std_mode", f"must be one of {', '.join(STD_MODES)}"),
        (ppo.matmul_precision in MATMUL_PRECISIONS, "ppo.matmul_precision",
         f"must be one of {', '.join(MATMUL_PRECISIONS)}"),
        (ppo.learning_rate_schedule in LR_SCHEDULES, "ppo.learning_rate_schedule",
         f"must be one of {', '.join(LR_SCHEDULES)}"),
        (ppo.learning_rate_final > 0, "ppo.learning_rate_final", "must be positive"),
        (0 < ppo.discounting <= 1, "ppo.discounting", "must be in (0, 1]"),
        (0 <= ppo.gae_lambda <= 1, "ppo.gae_lambda", "must be in [0, 1]"),
        (ppo.clipping_epsilon > 0, "ppo.clipping_epsilon", "must be positive (0 would keep the policy from moving)"),
        (ppo.entropy_cost >= 0, "ppo.entropy_cost", "must be >= 0 (0 = no entropy bonus)"),
        (ppo.max_grad_norm > 0, "ppo.max_grad_norm", "must be positive"),
        (ppo.reward_scaling > 0, "ppo.reward_scaling", "must be positive"),
        (ppo.min_action_std > 0, "ppo.min_action_std", "must be positive"),
        (ppo.init_action_std > ppo.min_action_std, "ppo.init_action_std",
         f"must be above ppo.min_action_std ({ppo.min_action_std})"),
        (ppo.max_kl >= 0, "ppo.max_kl", "must be >= 0 (0 = no limit)"),
        (len(ppo.policy_hidden) > 0 and all(h > 0 for h in ppo.policy_hidden), "ppo.policy_hidden",
         "needs at least one layer, every size positive (e.g. 1024,512)"),
        (len(ppo.value_hidden) > 0 and all(h > 0 for h in ppo.value_hidden), "ppo.value_hidden",
         "needs at least one layer, every size positive (e.g. 1024,512)"),
        (run.total_samples > 0, "run.total_samples", "must be positive"),
        (run.eval_every > 0, "run.eval_every", "must be positive"),
        (run.checkpoint_every > 0, "run.checkpoint_every", "must be positive"),
        (run.eval_episodes >= 1, "run.eval_episodes", "must be at least 1"),
        (run.max_seconds >= 0, "run.max_seconds", "must be >= 0"),
        (0 <= run.best_from_samples < run.total_samples, "run.best_from_samples",
         "must be >= 0 and below run.total_samples (no evaluation after it could be kept as the best)"),
        (0 <= run.target_nr <= 1, "run.target_nr", "must be in [0, 1] (an NR; 0 = never stop early)"),
        (0 <= run.seed <= SEED_MAX, "run.seed", f"must be in 0..{SEED_MAX}"),
    ]
    for ok, key, why in checks:
        if not ok:
            raise UserError(f"config key {key!r}: {why}")
    _check_term_names(config)


def _check_term_names(config: Config) -> None:
    """The names in the term lists, read by the parsers that the env's step is built from, so that
    a bad one is refused with the config (before a run, or each run of a sweep, starts to build)."""
    from mjxmimic.task import events, observation, reward  # they read this package's config types

    observation.parse(config.env.observations)
    events.parse(config.env.events)
    reward.terms(config.reward.kind, config.reward.weights)
