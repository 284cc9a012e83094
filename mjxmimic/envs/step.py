"""One control step, written once for every backend and both array modules:

    action -> PD targets (reference pose at the step's end) -> events (external forces)
    -> `substeps` of PD law + physics (under the episode's domain randomisation)
    -> kinematics of the body and the reference
    -> reward terms (the best over a dataset's clips with reward.combine=max; mixed with a task's
       reward, mjxmimic.task.goals) -> terminations -> observation terms (+ the task's goal)

The MJX env runs it vmapped under jit with jax.numpy; the CPU env runs it on MuJoCo C with numpy.
Per-env motion state (`Motion`: clip id, clip time, step count, root offset) is explicit data that
reset draws and the step advances, so every env may follow its own clip.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from mjxmimic.core.character import Character, default_fall_contact
from mjxmimic.core.config import Config
from mjxmimic.core.errors import UserError
from mjxmimic.core.layout import Layout, make_layout
from mjxmimic.core import terrain as terrain_lib
from mjxmimic.core.kinematics import ROOT_BODY, root_yaw
from mjxmimic.core.scene import Ball, Scene, build_scene, fall_mask, sensor_geoms
from mjxmimic.envs import entry as entry_lib
from mjxmimic.envs import skill_switch
from mjxmimic.envs import starts
from mjxmimic.motion import library as motion_lib
from mjxmimic.physics.backend import Physics
from mjxmimic.physics.pd import action_to_targets
from mjxmimic.physics import randomise
from mjxmimic.task import events as event_terms
from mjxmimic.task import goals
from mjxmimic.task import observation as obs_terms
from mjxmimic.task import reward as reward_terms
from mjxmimic.task import termination


class Motion(NamedTuple):
    """Per-env motion state."""

    clip: Any  # int clip id in the motion library
    time: Any  # clip time (s), float32
    steps: Any  # control steps since the reset
    root_offset: Any  # (2,) horizontal shift of the reference root (reward.sync_root_position)
    event_seed: Any  # in [0, 1), drawn at reset: what varies events (pushes, randomised physics) between episodes
    goal: Any  # (4,) a task's episode state (strike: target x, y, z and whether it was hit; throw:
    # target x, y, whether the ball landed, its distance from the target); else zeros
    settle: Any = 0  # control steps left in which a skill switch settles (env.skill_switch_settle_s)


class Spec(NamedTuple):
    """What the step needs besides the backend: built once per env, arrays in the step's xp."""

    layout: Layout
    lib: motion_lib.MotionLib
    fall_masks: Any  # (C, S) bool: per clip, the contact sensors that count as a fall
    reference_geoms: Any  # per contact sensor: body, centre offset, radius; None: DeepMimic's fall rule
    observations: tuple[str, ...]
    events: tuple[str, ...]
    rewards: tuple[reward_terms.Term, ...]
    paper_rewards: tuple[reward_terms.Term, ...]
    control_dt: float
    max_steps: int
    observation_size: int
    action_size: int
    task_body: int  # the strike task's striking body, the throw task's hand (-1 without one)
    config: Config
    terrain: Any = None  # mjxmimic.core.terrain.Terrain, its boxes in xp; None on the flat floor
    heightmap_offsets: Any = None  # (rows * cols, 2) the heightmap's grid in the heading frame
    ball: Ball | None = None  # the throw task's ball: its state follows the character's in qpos and qvel
    start_bank: StartBank | None = None  # env.start_states, matched to the clips (mjxmimic.envs.start_bank)
    switch_entry: entry_lib.Entry | None = None  # env.skill_switch_entry=nearest: the clips' entry grid


class StartBank(NamedTuple):
    """States that training episodes may start from, each at its clip and time (arrays in xp)."""

    qpos: Any  # (N, nq)
    qvel: Any  # (N, nv)
    clip: Any  # (N,) int32
    time: Any  # (N,) float32


class Result(NamedTuple):
    state: Any  # the backend's state
    motion: Motion
    obs: Any
    reward: Any
    done: Any  # failed | timeout | clip end
    failed: Any  # a termination term fired (reward 0, value target 0)
    truncation: Any  # the episode was cut without failing: a timeout, or a lost state (masked out of GAE)
    clip_end: Any
    metrics: dict[str, Any]


def fall_contact_spec(config: Config, clip_name: str) -> str:
    spec = config.clip.fall_contact
    return default_fall_contact(clip_name) if spec == "auto" else spec


def build(config: Config, character: Character, clips: list[Any], xp: Any, weights: Any = None) -> tuple[Scene, Spec]:
    """The physics scene and the step's static data for `clips`, arrays converted with `xp.asarray`."""
    env = config.env
    scene = build_scene(character, env.physics_hz, env.solver_iterations, env.ls_iterations,
                        terrain_lib.from_config(config.terrain), ball_of(config))
    return scene, make_spec(config, character, scene, clips, xp, weights)


def make_spec(config: Config, character: Character, scene: Scene, clips: list[Any], xp: Any,
              weights: Any = None) -> Spec:
    """The step's static data for `clips`, arrays converted with `xp.asarray`."""
    check_release(config, clips)
    masks = []
    for clip in clips:
        try:
            masks.append(fall_mask(scene, character, fall_contact_spec(config, clip.name)))
        except ValueError as err:
            raise UserError(f"config key 'clip.fall_contact': {err}") from None
    lib = motion_lib.build_motion_lib(clips, character, weights, config.clip.velocity)
    entry = skill_switch.entry_grid(config, scene, lib, xp) if len(clips) > 1 else None
    if xp is not np:
        lib = lib._replace(**{k: xp.asarray(v) for k, v in lib._asdict().items() if k != "layout"})
    env, terrain = config.env, terrain_lib.from_config(config.terrain)  # its boxes stay on the host
    return Spec(
        layout=make_layout(character),
        lib=lib,
        fall_masks=xp.asarray(np.stack(masks)),
        reference_geoms=(tuple(xp.asarray(a) for a in sensor_geoms(scene))
                      if config.env.fall_ignores_reference_contacts else None),
        observations=obs_terms.parse(env.observations),
        events=event_terms.parse(env.events),
        rewards=reward_terms.terms(config.reward.kind, config.reward.weights),
        paper_rewards=reward_terms.terms("paper"),
        control_dt=1.0 / env.control_hz,
        max_steps=int(round(env.episode_seconds * env.control_hz)),
        observation_size=observation_size(config, character.model.nbody, len(clips)),
        action_size=character.action_size,
        task_body=_task_body(config, scene),
        config=config,
        terrain=terrain,
        heightmap_offsets=None if terrain is None else xp.asarray(heightmap_grid(config)),
        ball=ball_of(config),
        switch_entry=entry,
    )


def ball_of(config: Config) -> Ball | None:
    """The throw task's ball (a baseball), else None."""
    return Ball() if config.task.name == "throw" else None


def check_release(config: Config, clips: list[Any]) -> None:
    """The throw task lets go within every clip."""
    if config.task.name != "throw":
        return
    for clip in clips:
        if config.task.release_s >= clip.duration:
            raise UserError(f"config key 'task.release_s': {config.task.release_s} s is not before the end of "
                            f"clip {clip.name!r} ({clip.duration:.2f} s)")


def heightmap_grid(config: Config) -> np.ndarray:
    t = config.terrain
    return terrain_lib.grid_offsets(*t.heightmap_shape, t.heightmap_spacing_m, t.heightmap_forward_m)


def observation_size(config: Config, nbody: int, nclips: int = 1) -> int:
    """The observation terms' numbers, then the task's goal, then a terrain's heightmap."""
    rows, cols = config.terrain.heightmap_shape
    heightmap = 0 if config.terrain.kind == "none" else rows * cols
    return (obs_terms.observation_size(nbody, config.env.observations, nclips) + goals.GOAL_SIZE[config.task.name]
            + heightmap)


def _task_body(config: Config, scene: Scene) -> int:
    """The strike task's striking body, the throw task's hand."""
    key = {"strike": "strike_body", "throw": "throw_hand"}.get(config.task.name)
    if key is None:
        return -1
    import mujoco

    name = getattr(config.task, key)
    body = mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_BODY, name)
    if not 0 < body < scene.nbody:
        raise UserError(f"config key 'task.{key}': the character has no body {name!r}")
    return body


def goal(spec: Spec, motion: Motion, xp: Any) -> tuple[Any, Any]:
    """The heading task's goal in force for the coming step: (direction yaw, speed); along the
    course (+x) on a terrain."""
    yaw, speed = goals.heading_goal(spec.config.task, spec.lib, motion.clip, motion.steps * spec.control_dt,
                                    motion.event_seed, xp)
    return (yaw if spec.terrain is None else xp.zeros_like(yaw)), speed


def split_ball(spec: Spec, qpos: Any, qvel: Any) -> tuple[Any, Any, Any, Any]:
    """(character qpos, qvel, ball qpos, ball qvel) of the scene's; the ball's are empty without one."""
    nq, nv = spec.layout.q_perm.shape[0], spec.layout.v_perm.shape[0]
    return qpos[:nq], qvel[:nv], qpos[nq:], qvel[nv:]


def with_ball(spec: Spec, physics: Physics, qpos: Any, qvel: Any) -> tuple[Any, Any]:
    """The scene's (qpos, qvel) for the character's: the ball appended in the hand, if there is one
    and it is not there yet."""
    xp = physics.xp
    if spec.ball is None or qpos.shape[0] > spec.layout.q_perm.shape[0]:
        return qpos, qvel
    ball_q, ball_v = goals.ball_in_hand(physics.kinematics(qpos, qvel), spec.task_body, xp)
    return xp.concatenate([qpos, ball_q.astype(qpos.dtype)]), xp.concatenate([qvel, ball_v.astype(qvel.dtype)])


def released(spec: Spec, clip_time: Any) -> Any:
    """Whether the throw task's ball flies freely from a control step boundary at `clip_time` on:
    the hand carries it to the first boundary at or after task.release_s (to within the 1e-4 s by
    which float32 clip times drift), and lets go there."""
    return clip_time >= spec.config.task.release_s - 1e-4


def observe(spec: Spec, physics: Physics, kin: Any, motion: Motion, ball: tuple[Any, Any] | None = None,
            ref_qpos: Any = None) -> Any:
    """The observation terms, then the goal when there is a task (DEEPMIMIC.md); `ball` (its free
    joint's qpos, qvel) for the throw task; `ref_qpos`, the reference as the reward graded it at
    `motion`'s time, where the caller has it (else sampled again, for reference_root)."""
    xp = physics.xp
    onehot = None
    if "skill" in spec.observations:
        onehot = (xp.arange(len(spec.lib.duration)) == motion.clip).astype(xp.float32)
    if "reference_root" in spec.observations and ref_qpos is None:
        ref_qpos, _ = graded_reference(spec, *motion_lib.sample(spec.lib, motion.clip, motion.time, xp), kin.qpos,
                                       motion.root_offset, xp)
    heading = spec.config.env.observation_heading
    obs = obs_terms.observe(spec.observations, kin, motion_lib.phase(spec.lib, motion.clip, motion.time, xp), xp,
                            onehot, ref_qpos, heading)
    frame_yaw = root_yaw(kin, xp, heading)  # what a task's goal and the heightmap are seen in
    task = spec.config.task.name
    if task == "heading":
        obs = xp.concatenate([obs, goals.goal_observation(frame_yaw, *goal(spec, motion, xp), xp)])
    elif task == "strike":
        obs = xp.concatenate([obs, goals.target_observation(kin, motion.goal, frame_yaw, xp)])
    elif task == "throw":
        obs = xp.concatenate([obs, goals.throw_observation(kin, motion.goal, ball[0][:3], ball[1][:3],
                                                           released(spec, motion.time), frame_yaw, xp)])
    if spec.terrain is not None:
        obs = xp.concatenate([obs, terrain_lib.heightmap(spec.terrain.boxes, spec.terrain.depth, spec.heightmap_offsets,
                                                         kin.xipos[ROOT_BODY], frame_yaw, xp)])
    return obs


def reset(spec: Spec, physics: Physics, clip: Any, t: Any, event_seed: Any = 0.0) -> tuple[Any, Motion, Any]:
    """(state, motion, obs): the reference state of `clip` at time t (RSI)."""
    xp = physics.xp
    t = xp.asarray(t, dtype=xp.float32)
    event_seed = xp.asarray(event_seed, xp.float32)
    qpos, qvel = starts.start_state(spec, clip, t, event_seed, xp)
    if spec.start_bank is not None:
        clip, t, qpos, qvel = starts.from_bank(spec, clip, t, qpos, qvel, event_seed, xp)
    qpos, qvel = with_ball(spec, physics, qpos, qvel)
    state = physics.init(qpos, qvel)
    motion = Motion(clip=clip, time=t, steps=xp.zeros((), xp.int32), root_offset=xp.zeros(2, xp.float32),
                    event_seed=event_seed, goal=initial_goal(spec, qpos, event_seed, xp),
                    settle=xp.zeros((), xp.int32))
    q, v, ball_q, ball_v = split_ball(spec, qpos, qvel)
    return state, motion, observe(spec, physics, physics.kinematics(q, v), motion, (ball_q, ball_v))


def initial_goal(spec: Spec, qpos: Any, event_seed: Any, xp: Any) -> Any:
    """Motion.goal at reset: the strike or throw target around the character, else zeros."""
    if spec.config.task.name == "strike":
        return goals.place_target(spec.config.task, qpos, event_seed, xp)
    if spec.config.task.name == "throw":
        return goals.throw_start(spec.config.task, qpos, event_seed, xp)
    return xp.zeros(4, xp.float32)


def graded_reference(spec: Spec, ref_qpos: Any, ref_qvel: Any, sim_qpos: Any, root_offset: Any,
                     xp: Any) -> tuple[Any, Any]:
    """The reference pose that the reward grades: its root moved by the root offset, or, under a
    task, turned and moved to the character (mjxmimic.task.goals.align_reference); on a terrain
    lifted by the height of the ground under the character (0 over a gap)."""
    if spec.config.task.name:
        ref_qpos, ref_qvel = goals.align_reference(ref_qpos, ref_qvel, sim_qpos, xp)
    else:
        ref_qpos = motion_lib.shift_root(ref_qpos, root_offset, xp)
    if spec.terrain is not None:  # on a step, the reference stands on it too (never sunk into a gap)
        lift = xp.maximum(terrain_lib.height(spec.terrain.boxes, spec.terrain.depth, sim_qpos[0:2], xp), 0.0)
        ref_qpos = xp.concatenate([ref_qpos[0:2], ref_qpos[2:3] + lift, ref_qpos[3:]])
    return ref_qpos, ref_qvel


def best_clip_reward(spec: Spec, physics: Physics, sim: Any, qpos: Any, phase: Any) -> Any:
    """DeepMimic's multi-clip reward: the imitation reward against each clip of the library at
    the same phase, its reference turned and moved to the character, and the best of them."""
    xp, lib = physics.xp, spec.lib

    def against(c: Any) -> Any:
        ref_qpos, ref_qvel = motion_lib.sample(lib, c, phase * lib.duration[c], xp)
        ref = physics.kinematics(*goals.align_reference(ref_qpos, ref_qvel, qpos, xp))
        return reward_terms.reward(spec.rewards, spec.layout, sim, ref, xp)[0]

    count = len(lib.duration)
    if xp is np:
        return max(against(c) for c in range(count))
    import jax

    return xp.max(jax.vmap(against)(xp.arange(count)))


def control_step(spec: Spec, physics: Physics, state: Any, motion: Motion, action: Any,
                 terminations: tuple[str, ...], external_force: Any = None, grade_paper: bool = False,
                 push_scale: Any = 1.0) -> Result:
    """One control step (the module docstring); no reset. `external_force` (nbody, 6) is added to
    the events' own; `push_scale` scales the events' (the push curriculum)."""
    xp, env, lib = physics.xp, spec.config.env, spec.lib
    clip = motion.clip
    t = motion.time + xp.asarray(spec.control_dt, xp.float32)
    ref_qpos, ref_qvel = motion_lib.sample(lib, clip, t, xp)  # the unshifted root
    targets = action_to_targets(spec.layout, action, ref_qpos, env.action_mode, env.action_scale, xp)
    nbody = spec.layout.body_mass.shape[0]
    rows = nbody if external_force is None else external_force.shape[0]  # a caller's may cover a ball's body
    facing_pushes = bool(spec.events) and env.push_directions == "table6"  # static: they need the pose
    now = physics.qpos_qvel(state)[0] if facing_pushes else None
    events = event_terms.external_force(spec.events, env, motion.steps * spec.control_dt, motion.event_seed, rows, xp,
                                        now, push_scale)
    if events is not None or external_force is not None:
        external_force = (0.0 if events is None else events) + (0.0 if external_force is None else external_force)
    scales = randomise.draw(env, motion.event_seed, nbody, xp)
    sub = physics.step(state, targets, external_force, scales)
    qpos, qvel, ball_q, ball_v = split_ball(spec, *physics.qpos_qvel(sub.state))
    sim = physics.kinematics(qpos, qvel)
    if spec.ball is not None:  # the hand carries the ball to the release time
        held = ~released(spec, motion.time)
        hand_q, hand_v = goals.ball_in_hand(sim, spec.task_body, xp)
        ball_q, ball_v = xp.where(held, hand_q, ball_q), xp.where(held, hand_v, ball_v)
        sub = sub._replace(state=physics.with_qpos_qvel(sub.state, xp.concatenate([qpos, ball_q]),
                                                        xp.concatenate([qvel, ball_v])))
    task = spec.config.task
    offset = motion.root_offset
    if spec.config.reward.sync_root_position and not task.name:  # a task's reference follows the character
        offset = motion_lib.sync_root_offset(lib, clip, motion.time, t, offset, qpos[0:2], ref_qpos[0:2], xp)
    settles = env.skill_switch_settle_s > 0 or env.push_settle_s > 0  # static: traced only with a window
    if env.push_settle_s > 0 and events is not None:  # a push (re)opens the window until its end + push_settle_s
        window = xp.asarray(round(env.push_settle_s / spec.control_dt)).astype(xp.asarray(motion.settle).dtype)
        motion = motion._replace(settle=xp.where(xp.any(events != 0), xp.maximum(motion.settle, window),
                                                 motion.settle))
    settling = motion.settle > 0
    if settles:  # the reference root follows the character
        offset = xp.where(settling, qpos[0:2] - ref_qpos[0:2], offset)
    graded_qpos, graded_qvel = graded_reference(spec, ref_qpos, ref_qvel, qpos, offset, xp)
    ref = physics.kinematics(graded_qpos, graded_qvel)
    r, metrics = reward_terms.reward(spec.rewards, spec.layout, sim, ref, xp)
    if spec.config.reward.combine == "max":
        metrics["reward/own_clip"] = r
        r = best_clip_reward(spec, physics, sim, qpos, motion_lib.phase(lib, clip, t, xp))
    metrics["reward/imitation"] = r
    metrics.update(randomise.metrics(scales, xp))
    goal_state = motion.goal
    if task.name == "heading":
        yaw, speed = goal(spec, motion, xp)
        along = goals.speed_along(sim, spec.layout.body_mass, yaw, xp)
        r_task = goals.heading_reward(along, speed, xp)
        metrics.update({"reward/task": r_task, "task/speed_along": along, "task/speed": speed})
    elif task.name == "strike":
        r_task, goal_state, distance = goals.strike(task, sim, spec.task_body, motion.goal, xp)
        hit = goal_state[3]
        goal_state, new_target, whole = goals.renew_target(task, lib, clip, motion.time, t, qpos, motion.event_seed,
                                                           goal_state, xp)
        metrics.update({"reward/task": r_task, "task/hit": hit, "task/distance": distance,
                        "task/new_hit": hit - motion.goal[3],
                        "task/new_target": new_target.astype(xp.float32),
                        "task/whole_cycle_hit": xp.where(whole, hit, 0.0).astype(xp.float32)})
    elif task.name == "throw":
        r_task, goal_state, distance, hit = goals.throw(task, ball_q[:3], ball_v[:3], released(spec, t),
                                                        spec.ball.radius_m, motion.goal, xp)
        metrics.update({"reward/task": r_task, "task/hit": hit.astype(xp.float32), "task/distance": distance})
    if task.name:
        r = task.imitation_weight * r + task.task_weight * metrics["reward/task"]

    outcome = termination.Outcome(sim=sim, ref=ref, contacts=sub.contacts, fall_mask=spec.fall_masks[clip],
                                  reference_geoms=spec.reference_geoms,
                                  diverged=sub.diverged, max_joint_velocity=env.max_joint_velocity,
                                  pose_termination_m=env.pose_termination_m,
                                  pit_z=-spec.config.terrain.fall_margin_m if spec.terrain is not None else None,
                                  pose_from_root=env.pose_termination_frame == "root")
    fired = {name: termination.TERMS[name](outcome, xp) for name in terminations}
    if settles and "pose_deviation" in fired:
        fired["pose_deviation"] = fired["pose_deviation"] & ~settling
    bad = fired.get("bad_state", xp.zeros((), bool))
    failed = xp.zeros((), bool)
    for flag in fired.values():
        failed = failed | flag
    steps = motion.steps + 1
    timeout = steps >= spec.max_steps
    switching = env.skill_switch_s > 0 and lib.duration.shape[0] > 1
    # with switches, a one-off clip's end hands over to another clip (skill_switch.maybe_switch_skill)
    clip_end = xp.zeros((), bool) if switching else motion_lib.ended(lib, clip, t, xp)
    done = failed | timeout | clip_end
    r = xp.where(failed, 0.0, r)
    metrics["reward/imitation"] = xp.where(failed, 0.0, metrics["reward/imitation"])

    t_before = motion.time
    motion = motion._replace(time=t, steps=steps, root_offset=offset, goal=goal_state)
    if settles:
        motion = motion._replace(settle=xp.maximum(motion.settle - 1, 0))
    if switching:
        motion = skill_switch.maybe_switch_skill(spec, motion, t_before, qpos, done, xp, sim)
    obs = observe(spec, physics, sim, motion, (ball_q, ball_v), None if switching else graded_qpos)
    obs = xp.where(bad, 0.0, xp.nan_to_num(obs))
    metrics = {k: xp.where(bad, 0.0, xp.nan_to_num(v)) for k, v in metrics.items()}
    if grade_paper:
        paper, _ = reward_terms.reward(spec.paper_rewards, spec.layout, sim, ref, xp)
        metrics["reward_paper"] = xp.where(failed, 0.0, xp.nan_to_num(paper))
    metrics.update({"reward": r, "fell": (fired.get("fall", xp.zeros((), bool))
                                                       | fired.get("pit", xp.zeros((), bool))).astype(xp.float32),
                    "lost_track": fired.get("pose_deviation", xp.zeros((), bool)).astype(xp.float32),
                    "physics/reset_nan": bad.astype(xp.float32)})
    if spec.terrain is not None:
        metrics["terrain/x"] = qpos[0]
    truncation = (timeout & ~failed & ~clip_end) | bad
    return Result(state=sub.state, motion=motion, obs=obs, reward=r, done=done, failed=failed,
                  truncation=truncation, clip_end=clip_end, metrics=metrics)
