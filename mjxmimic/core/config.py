"""One typed configuration: frozen dataclasses in sections, named presets
(mjxmimic.core.presets), `section.key=value` overrides, and a JSON round trip (the resolved
config is written into every run folder)."""

from __future__ import annotations

import dataclasses
import json
import typing
from pathlib import Path
from typing import Any

from mjxmimic.core.errors import UserError
from mjxmimic.core.presets import PRESETS, TASK_DEFAULTS


@dataclasses.dataclass(frozen=True)
class CharacterConfig:
    xml: str = "humanoid.xml"  # a character NAME (humanoid, dog3d), a file in core/characters/, or a path


# Seeds are 32-bit: JAX's keys keep only a seed's low 32 bits (2**63 does not convert at all), and
# numpy's generators take no negative numbers.
SEED_MAX = 2**32 - 1


@dataclasses.dataclass(frozen=True)
class ClipConfig:
    name: str = "slow_walk"  # NAME (see `mjxmimic clips list`) or PATH
    fall_contact: str = "auto"  # auto: by clip name (DEEPMIMIC.md); else a body set like "all-feet"
    # reference joint velocities between frames: forward differences blended (they lead the pose by
    # half a frame) or central differences blended (experiments/paper_form/reference_velocity.py)
    velocity: str = "forward"


@dataclasses.dataclass(frozen=True)
class EnvConfig:
    control_hz: int = 30
    physics_hz: int = 240  # must be a multiple of control_hz
    solver_iterations: int = 4  # Newton; 3 already changes a trained walk's NR (0.92 -> 0.75)
    ls_iterations: int = 4  # line search; 4 instead of 8: walk NR 0.916 vs 0.919, 1.14x the samples/s
    episode_seconds: float = 20.0  # time limit (a timeout, not a failure)
    rsi: bool = True  # reset to a random reference time; else to the clip's start
    early_termination: bool = True
    # A fall-contact body touching the floor is no fall while the reference's same geom is on the
    # floor too (within 5 cm, by its bounding sphere): a getup or a roll starts or passes lying
    # down. DeepMimic's rule, false here, ends such episodes at once.
    fall_ignores_reference_contacts: bool = True
    # Training only: a step on which some body's centre is more than this far (m) from the
    # reference's ends the episode as a failure, so that standing still while the reference flips
    # is no better than falling (MimicKit's DeepMimic setup uses 1.0). 0 = off (DeepMimic's).
    # NR evaluation ignores it: EVALUATION.md ends episodes on falls only.
    pose_termination_m: float = 0.0
    # "world": the bodies' centres compared where they are; "root": with the reference moved
    # sideways onto the character's root first (heights kept), so that being pushed off the
    # reference's path ends no episode and a policy may learn to recover, while a wrong pose does.
    # make_config picks "root" for runs with pushes unless told otherwise (experiments/robustness)
    pose_termination_frame: str = "world"
    # "total" (DeepMimic's): each joint's torque limit bounds its whole PD torque, damping included;
    # "proportional": the law of runs made before this key existed (mjxmimic.physics.pd says why not).
    torque_limit: str = "total"
    max_joint_velocity: float = 100.0  # beyond this (or NaN) the state is discarded and reset
    # "residual": PD targets = reference pose turned by the action (experiments/sweeps: NR 0.49 vs
    # 0.40 for walk after 10 M samples); "absolute": DeepMimic's, the action spans each joint's range.
    action_mode: str = "residual"
    action_scale: float = 1.0  # absolute: 1 spans +-pi (ball) and the range (hinge); residual: rad
    observations: str = "phase,root_height,bodies"  # observation terms, in order (mjxmimic.task.observation)
    # the observation's heading frame: "forward", the yaw of the root's forward axis (DeepMimic's),
    # or "twist", the twist of the root's rotation about the vertical (steady where the root faces
    # the floor, as in the crawl)
    observation_heading: str = "forward"
    events: str = ""  # episode events, e.g. "push" (mjxmimic.task.events); none by default
    push_force_n: float = 0.0  # horizontal force on the root (N)
    # > 0: each push's force is drawn in [push_force_n, push_force_max_n] (mjxmimic.task.events);
    # 0: every push is push_force_n
    push_force_max_n: float = 0.0
    push_duration_s: float = 0.2
    push_interval_s: float = 2.0  # one push every interval, from the second on
    push_interval_jitter_s: float = 0.0  # each push starts up to this long after its interval's start
    # "any": each push in a direction uniform over the compass; "table6": forward, or to the left or
    # right, of the character's facing (half of the pushes forward), the directions Table 6 tests
    push_directions: str = "any"
    # with push_directions=table6: the sideways pushes' force times this, e.g. Table 6's sideways
    # force over its forward one, so that sideways pushes are not trained far past their target
    push_sideways_scale: float = 1.0
    # > 0: a curriculum: every push's force is scaled by (training samples so far) / this, up to 1,
    # so that a policy learns the clip before the largest pushes come; 0: full force from the start
    push_ramp_samples: int = 0
    # > 0: no pushes before this many training samples (the ramp, if any, starts here), so that a
    # policy first learns the clip as one trained without pushes does, then to withstand pushes
    push_start_samples: int = 0
    # > 0: no pushes from this many training samples on, so that a push-trained policy ends its
    # training on the clip alone (the NR is graded without pushes); 0: pushes to the end
    push_stop_samples: int = 0
    # the share of training episodes that are pushed at all (drawn from each episode's event seed),
    # so that the rest keep teaching the clip as it is graded; 1: every episode
    push_episode_share: float = 1.0
    # > 0: for this many seconds after each push (counted from its end) the reference root follows
    # the character horizontally and a pose deviation ends no training episode, as after a skill
    # switch, so that the pose termination may stay in the world frame (the preset's) while a push
    # off the reference's path still teaches recovery; make_config then keeps the world frame;
    # training only; 0 = off
    push_settle_s: float = 0.0
    # Domain randomisation (mjxmimic.physics.randomise), per episode; (1, 1) = off. Factors (lo,
    # hi): one for every geom's sliding friction, one per body for its mass and inertia.
    friction_range: tuple[float, ...] = (1.0, 1.0)
    mass_range: tuple[float, ...] = (1.0, 1.0)
    # > 0: each episode starts from its RSI pose with every actuated joint turned by up to this
    # many radians (uniform per hinge angle and per component of a ball joint's rotation vector),
    # so that the policy meets states off its clip (a getup: the poses a push leaves); training only
    reset_noise_rad: float = 0.0
    # (lo, hi): each episode's RSI velocities (root and joints) scaled by one factor uniform in
    # [lo, hi], so that a policy also starts from slower or still states (a walk handed a standing
    # character by a getup, issue 14); (1, 1) = off; training only
    reset_velocity_range: tuple[float, ...] = (1.0, 1.0)
    # start_states_fraction of the training episodes start instead from a state of the file
    # start_states (.npz: qpos (N, nq), qvel (N, nv) of the character, e.g. bodies knocked down:
    # `mjxmimic play COMPOSITE --knockdowns N --save-states`), at the clip time whose reference pose is nearest,
    # turned and moved onto that reference (mjxmimic.envs.start_bank); training only
    start_states: str = ""
    start_states_fraction: float = 0.0
    # > 0: on a dataset with the skill observation, training switches an episode's clip to another
    # (drawn uniformly) on average every this many seconds, as a user's switch at play time
    # (mjxmimic.envs.skill_switch), its reference root moved under the character: a selector
    # trained only on episodes of one clip falls when the user switches (experiments/README.md);
    # 0 = never; training only
    skill_switch_s: float = 0.0
    # where a switch between cyclic clips enters the new one, in training and at play time: "phase"
    # (the same phase) or "nearest" (its reference pose nearest the character's, mjxmimic.envs.entry)
    skill_switch_entry: str = "phase"
    # > 0: for this many seconds after a switch the reference root follows the character
    # horizontally and a pose deviation does not end a training episode, so that a switch to a
    # clip of another speed (run to walk) can be learnt: without it the 1 m rule ends such an
    # episode within 0.3 to 0.7 s (experiments/README.md); 0 = off
    skill_switch_settle_s: float = 0.0


@dataclasses.dataclass(frozen=True)
class PhysicsConfig:
    # "auto": MJX's warp implementation on a CUDA GPU with warp-lang installed, else impl="jax"
    backend: str = "auto"
    # warp sizes its contact pool and constraint rows up front: per env (world)
    contacts_per_world: int = 32
    constraints_per_world: int = 160


@dataclasses.dataclass(frozen=True)
class RewardConfig:
    kind: str = "released"  # "released" (five terms) or "paper" (four terms)
    # At each new cycle of a looping clip, move the reference root horizontally under the
    # character (DeepMimic's released sync_char_root_pos, on by default there); off: the reference
    # root runs on its own and drift costs root reward for the rest of the episode.
    sync_root_position: bool = True
    weights: str = ""  # "term=weight,...": re-weight terms of the chosen reward (0 drops one)
    # "own": graded against the env's own clip; "max": the best over the dataset's clips at the
    # same phase, each reference turned and moved to the character (DeepMimic's multi-clip reward)
    combine: str = "own"


@dataclasses.dataclass(frozen=True)
class TaskConfig:
    name: str = ""  # "" (imitation only), "heading", "strike" or "throw" (mjxmimic.task.goals)
    imitation_weight: float = 0.7  # r = imitation_weight * r_imitation + task_weight * r_task
    task_weight: float = 0.3
    speed: float = 0.0  # heading: commanded speed (m/s); 0 = the clip's own average speed
    resample_s: float = 5.0  # heading: a new direction every this many seconds of the episode
    strike_body: str = "right_ankle"  # strike: the body whose centre must reach the target
    target_min_m: float = 0.5  # strike, throw: the target's horizontal distance from the root at reset,
    target_max_m: float = 1.0  # uniform in [min, max], in any direction (throw: presets.TASK_DEFAULTS)
    target_height_m: float = 1.2  # strike: the target centre's height
    # strike on a looping clip: a new target (hit flag cleared) around the character at each new
    # cycle of the clip, so that every kick has a target in reach; False: one per episode
    target_each_cycle: bool = False
    target_radius_m: float = 0.2  # strike: a hit is the striking body's centre within this radius;
    # throw: the ball lands (its centre first at its radius above the floor) within it
    throw_hand: str = "right_wrist"  # throw: the body that holds the ball
    # throw: the clip time (s) at which the hand lets go; the project's pitch clip's
    # (mjxmimic/motion/clips/make_clips.py PITCH_RELEASE_S; a test keeps them equal)
    release_s: float = 1.1
    # throw: k of r_task = exp(-k max(0, d - radius)^2), d the ball's (predicted) landing distance
    # from the target in m; larger k tells a near miss from a hit more sharply
    throw_shape: float = 0.5


@dataclasses.dataclass(frozen=True)
class TerrainConfig:
    # "none" (flat floor), or a course kind of mjxmimic.core.terrain: gaps, beam, stairs, mixed
    kind: str = "none"
    seed: int = 0  # the courses drawn (lane l from (seed, l)); the same in training and playback
    difficulty: float = 0.5  # in [0, 1]: gap width, beam width and winding, step rise, block height
    lanes: int = 4  # courses side by side; each env starts on the lane its episode seed picks
    length_m: float = 15.0  # a course's length: reaching its end (x = length) is success
    lane_width_m: float = 3.0
    depth_m: float = 2.0  # gaps and the ground beside the beam drop this deep (deeper than a standing root, 0.9 m)
    fall_margin_m: float = 0.3  # the root this far below z = 0 (every walkable top is >= 0) is a fall
    # the heightmap observation: rows along the facing x columns across it, spacing (m), its
    # centre this far ahead of the root; appended after the state and the goal. 8 x 8 at 0.2 m
    # covers what 16 x 16 at 0.1 m does at a lower learner cost (experiments/terrain/README.md)
    heightmap_shape: tuple[int, ...] = (8, 8)
    heightmap_spacing_m: float = 0.2
    heightmap_forward_m: float = 0.5


@dataclasses.dataclass(frozen=True)
class PPOConfig:
    num_envs: int = 8192
    unroll_length: int = 16
    num_minibatches: int = 8
    num_epochs: int = 4
    learning_rate: float = 3e-4
    # "constant", or "linear" / "cosine": from learning_rate at 0 samples down to
    # learning_rate_final at run.total_samples (a fixed sample budget, e.g. one device call).
    learning_rate_schedule: str = "constant"
    learning_rate_final: float = 3e-5
    entropy_cost: float = 0.0
    discounting: float = 0.95
    gae_lambda: float = 0.95
    clipping_epsilon: float = 0.2
    max_grad_norm: float = 1.0
    reward_scaling: float = 1.0
    normalize_observations: bool = True
    policy_hidden: tuple[int, ...] = (1024, 512)
    value_hidden: tuple[int, ...] = (1024, 512)
    init_action_std: float = 0.2  # Gaussian std at the start (normalised action units)
    # "learned": the std is an output of the policy, trained with it; "fixed": it stays
    # init_action_std in every state (DeepMimic's fixed exploration noise)
    std_mode: str = "learned"
    # the learned std never falls below this (NormalTanhDistribution's min_std, added to the
    # softplus; Brax's default 0.001): a std far below the mean's step size turns one update
    # into a huge probability ratio (DeepMimic's fixed std was 0.05)
    min_action_std: float = 0.001
    # a minibatch step that takes the policy further than this mean KL (on its minibatch, from
    # the policy that gathered the batch) is undone, and the iteration's later steps are
    # skipped; 0 = never
    max_kl: float = 0.0
    # the networks' matrix products in rollouts and updates, as JAX's dot algorithm presets:
    # "default" (XLA's choice), "BF16_BF16_F32", "TF32_TF32_F32" (GPU only) or "F32_F32_F32";
    # physics and the reward are not affected
    matmul_precision: str = "default"


@dataclasses.dataclass(frozen=True)
class RunConfig:
    total_samples: int = 100_000_000
    max_seconds: float = 0.0  # stop (with a checkpoint) after this wall-clock time; 0 = no limit
    eval_every: int = 10_000_000  # samples between evaluations
    checkpoint_every: int = 10_000_000  # samples between checkpoints
    eval_episodes: int = 64
    target_nr: float = 0.0  # stop once an evaluation reaches this NR; 0 = never
    seed: int = 0  # PRNG seed of the run (network init, env resets, evaluation start times)
    eval_at_start: bool = False  # also evaluate the untrained policy (a baseline line in metrics.jsonl)
    # also grade the stochastic (training) policy on the same starts: stochastic_* beside the NR of
    # the deterministic one, which is what playback and export run
    eval_stochastic: bool = False
    wandb_project: str = ""  # also log to this Weights & Biases project (mjxmimic.runs.wandb_log); "" = off
    wandb_videos: bool = True  # with W&B: a video of each new best policy, where rendering works
    # a policy file or run folder whose networks and observation normaliser start a new run
    # (mjxmimic.runs.warm_start: fine-tuning a learnt skill with pushes, terrain or a task); "" = none
    init_from: str = ""
    # no evaluation before this many samples is kept as the best checkpoint (what export, play and
    # the push test take), e.g. the end of a fine-tuning's pushes; besides that, a run never keeps
    # one from before its pushes reach full force (env.push_start_samples + env.push_ramp_samples)
    best_from_samples: int = 0


@dataclasses.dataclass(frozen=True)
class Config:
    character: CharacterConfig = CharacterConfig()
    clip: ClipConfig = ClipConfig()
    env: EnvConfig = EnvConfig()
    physics: PhysicsConfig = PhysicsConfig()
    reward: RewardConfig = RewardConfig()
    task: TaskConfig = TaskConfig()
    terrain: TerrainConfig = TerrainConfig()
    ppo: PPOConfig = PPOConfig()
    run: RunConfig = RunConfig()


LR_SCHEDULES = ("constant", "linear", "cosine")
REFERENCE_VELOCITIES = ("forward", "central")  # clip.velocity: how frames give the reference its velocities
STD_MODES = ("learned", "fixed")
MATMUL_PRECISIONS = ("default", "BF16_BF16_F32", "TF32_TF32_F32", "F32_F32_F32")
TASKS = ("heading", "strike", "throw")  # mjxmimic.task.goals
TERRAINS = ("gaps", "beam", "stairs", "mixed")  # mjxmimic.core.terrain


def _coerce(value: str, typ: Any, key: str) -> Any:
    """Parse a command-line string into the type of a config field."""
    try:
        if typ is bool:
            if value.lower() in ("true", "1", "yes"):
                return True
            if value.lower() in ("false", "0", "no"):
                return False
            raise ValueError(value)
        if typ is int:
            return int(float(value)) if "e" in value.lower() else int(value)
        if typ is float:
            return float(value)
        if typ is str:
            return value
        if typing.get_origin(typ) is tuple:
            inner = value.strip("()[] ")
            parts = inner.split(",") if inner else []
            if any(not p.strip() for p in parts):  # "64,,64": a size left out, not a layer less
                raise ValueError(value)
            return tuple(typing.get_args(typ)[0](p) for p in parts)
    except ValueError:
        pass
    name = getattr(typ, "__name__", str(typ))
    raise UserError(f"config key {key!r}: {value!r} is not a valid {name}")


def _field_types(section_cls: type) -> dict[str, Any]:
    hints = typing.get_type_hints(section_cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(section_cls)}


def apply_overrides(config: Config, overrides: dict[str, Any]) -> Config:
    """Return `config` with `section.key` values replaced; strings are parsed to the field's type."""
    sections = {f.name: getattr(config, f.name) for f in dataclasses.fields(config)}
    for key, value in overrides.items():
        if key.count(".") != 1:
            raise UserError(f"config key {key!r}: expected section.key (sections: {', '.join(sections)})")
        section, name = key.split(".")
        if section not in sections:
            raise UserError(f"config key {key!r}: no section {section!r} (sections: {', '.join(sections)})")
        types = _field_types(type(sections[section]))
        if name not in types:
            raise UserError(f"config key {key!r} does not exist ({section} has: {', '.join(types)})")
        typ = types[name]
        if isinstance(value, str) and typ is not str:
            value = _coerce(value, typ, key)
        elif typing.get_origin(typ) is tuple and isinstance(value, (list, tuple)):
            value = _coerce(",".join(str(v) for v in value), typ, key)  # JSON lists, Python tuples
        elif typ is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        sections[section] = dataclasses.replace(sections[section], **{name: value})
    result = Config(**sections)
    from mjxmimic.core.config_checks import validate  # it reads this module's types

    validate(result)
    return result


def parse_set_args(items: list[str]) -> dict[str, str]:
    """`["ppo.learning_rate=3e-4", ...]` -> {"ppo.learning_rate": "3e-4", ...}."""
    out = {}
    for item in items:
        if "=" not in item:
            raise UserError(f"--set {item!r}: expected section.key=value")
        key, value = item.split("=", 1)
        out[key.strip()] = value.strip()
    return out


def make_config(preset: str = "gpu", overrides: dict[str, Any] | None = None) -> Config:
    """A preset plus overrides, validated."""
    if preset not in PRESETS:
        raise UserError(f"preset {preset!r} does not exist (presets: {', '.join(PRESETS)})")
    config = apply_overrides(Config(), PRESETS[preset])
    task = (overrides or {}).get("task.name", config.task.name)
    config = apply_overrides(config, TASK_DEFAULTS.get(task, {}))
    config = apply_overrides(config, overrides or {})
    if (has_pushes(config.env) and config.env.push_settle_s == 0
            and "env.pose_termination_frame" not in (overrides or {})):
        # in the world frame a push off the reference's path ends the very episodes that teach recovery
        config = apply_overrides(config, {"env.pose_termination_frame": "root"})
    return config


def names_in(value: str) -> tuple[str, ...]:
    """The names that a comma-separated key such as env.events lists."""
    return tuple(n.strip() for n in value.split(",") if n.strip())


def has_pushes(env: EnvConfig) -> bool:
    return "push" in names_in(env.events)


def push_curriculum(env: EnvConfig) -> bool:
    """Whether the trainer scales the pushes by training progress (a ramp, a late start, an early stop)."""
    return env.push_ramp_samples > 0 or env.push_start_samples > 0 or env.push_stop_samples > 0


def evaluation_config(config: Config) -> Config:
    """The conditions that evaluation, push tests and playback measure in (EVALUATION.md): the
    run's settings without what only perturbs training (episode events such as pushes, domain
    randomisation, reset noise), so that a policy trained with them is graded as any other."""
    return apply_overrides(config, {"env.events": "", "env.push_ramp_samples": 0, "env.push_start_samples": 0,
                                    "env.push_stop_samples": 0, "env.push_episode_share": 1.0, "env.push_settle_s": 0.0,
                                    "env.friction_range": (1.0, 1.0), "env.mass_range": (1.0, 1.0),
                                    "env.reset_noise_rad": 0.0, "env.reset_velocity_range": (1.0, 1.0),
                                    "env.start_states_fraction": 0.0, "env.skill_switch_s": 0.0})


PLAYBACK_SOLVER_ITERATIONS = (100, 50)  # MuJoCo's own defaults: Newton, line search


def playback_config(config: Config, solver_iterations: int | None = None) -> Config:
    """`evaluation_config` for MuJoCo's CPU simulator (play, render, the CPU push test). Its
    Newton solve may run to MuJoCo's default limits, stopping at its tolerance: MJX-Warp, where
    policies train, reaches a converged solve within the gpu preset's 4 iterations and MuJoCo C
    does not, so MuJoCo C at the training's count plays other physics (experiments/README.md,
    "Playback with a converged solve"). `solver_iterations` sets both limits instead."""
    newton, line_search = ((solver_iterations, solver_iterations) if solver_iterations is not None
                           else (max(PLAYBACK_SOLVER_ITERATIONS[0], config.env.solver_iterations),
                                 max(PLAYBACK_SOLVER_ITERATIONS[1], config.env.ls_iterations)))
    return apply_overrides(evaluation_config(config), {"env.solver_iterations": newton,
                                                      "env.ls_iterations": line_search})


def to_dict(config: Config) -> dict[str, dict[str, Any]]:
    return {f.name: dataclasses.asdict(getattr(config, f.name)) for f in dataclasses.fields(config)}


def from_dict(data: dict[str, Any]) -> Config:
    """Inverse of `to_dict`; unknown sections or keys are errors. A run written before
    env.torque_limit existed trained with the "proportional" law, and keeps it."""
    flat = {}
    for section, values in data.items():
        if not isinstance(values, dict):
            raise UserError(f"config section {section!r}: expected a mapping")
        flat.update({f"{section}.{k}": v for k, v in values.items()})
    if "env" in data:
        flat.setdefault("env.torque_limit", "proportional")
    return apply_overrides(Config(), flat)


def save(config: Config, path: Path) -> None:
    path.write_text(json.dumps(to_dict(config), indent=2) + "\n")


def load(path: Path) -> Config:
    if not path.is_file():
        raise UserError(f"{path}: config file not found")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise UserError(f"{path}: not valid JSON ({err.msg} at line {err.lineno})") from None
    if not isinstance(data, dict):
        raise UserError(f"{path}: expected a JSON object of config sections, got {type(data).__name__}")
    return from_dict(data)
