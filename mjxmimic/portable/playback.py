"""CPU playback: the training environment's control step on MuJoCo's C simulator, numpy only.

No JAX on this path (a test runs `mjxmimic play` and checks that `jax` was never imported), so an
exported policy runs wherever numpy and mujoco do.

`CpuEpisode` mirrors `mjxmimic.envs.mjx_env.ImitationEnv` line for line, with the very same functions for
everything that is not the simulator itself:

    reset_at(t):  the reference state at clip time t (motion.sample), MuJoCo kinematics,
                  observation with phase(t).
    step(action): t += 1 / control_hz; targets = control.action_to_targets(action, reference pose
                  at t); `substeps` times: qfrc_applied = control.pd_forces(...), mujoco.mj_step;
                  a fall is any contact (dist < 0) of a fall-contact geom in any substep; then
                  MuJoCo kinematics of the simulated and the reference state, reward.reward,
                  done = fall | NaN or |qvel| > env.max_joint_velocity | time limit | end of a
                  non-looping clip; a failed step scores 0; observation with phase(t).

`evaluate` is EVALUATION.md's NR protocol run on the CPU ("sim-to-sim NR"), counted exactly as
mjxmimic.runs.evaluate counts on MJX: deterministic policy, one episode per start time (RSI), horizon
600 control steps for a looping clip (env.episode_seconds at env.control_hz) or to the clip's end,
every step after a failure counting 0; NR = mean over episodes of (sum of rewards) / (steps in
the horizon); fall rate, survival time, pose and end-effector errors as mjxmimic.runs.evaluate defines
them. Start times: the MJX evaluation's own (carried in the exported file), or a seeded draw.

Simulator differences (measured, not playback errors). MJX's plane-box collision keeps only the
box corners within 1 mm of the deepest one, MuJoCo C every penetrating corner; so the feet touch
the floor through sole spheres (mjxmimic/core/characters/humanoid.xml), which both treat alike. With a converged
contact solve one control step then agrees to < 1e-3 in every observation entry, on the ground
and in the air (tests/test_export_playback.py). With few Newton iterations (the gpu preset's 4)
the two solvers stop at different points; the GPU-trained walk still scores 0.914 on CPU against
0.919 on MJX (README).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, NamedTuple

import mujoco
import numpy as np

from mjxmimic.motion import library as motion_lib
from mjxmimic.core.character import Character, default_fall_contact, physics_model
from mjxmimic.core.config import Config
from mjxmimic.physics.pd import action_to_targets, pd_forces
from mjxmimic.core.errors import UserError
from mjxmimic.core.kinematics import kin_from_data
from mjxmimic.core.layout import make_layout
from mjxmimic.task.observation import observation
from mjxmimic.task.reward import reward

_BAD_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL,
                 mujoco.mjtWarning.mjWARN_BADQPOS)


class Step(NamedTuple):
    obs: np.ndarray
    reward: float
    done: bool
    fell: bool
    bad: bool  # NaN or exploding state (counts as a failure, like a fall)
    truncated: bool  # the env's time limit, not a failure (info["truncation"])
    metrics: dict[str, float]


class CpuEpisode:
    """One character on one clip on MuJoCo's CPU simulator; the env's reset and transition."""

    def __init__(self, config: Config, character: Character, clip: Any):
        cfg = config.env
        self.config = config
        self.character = character
        self.clip = clip
        self.model = physics_model(character, cfg.physics_hz, cfg.solver_iterations, cfg.ls_iterations)
        self.data = mujoco.MjData(self.model)
        self._ref = mujoco.MjData(self.model)
        self.layout = make_layout(character)
        self.motion = motion_lib.build_motion_lib([clip], character)
        self.substeps = cfg.physics_hz // cfg.control_hz
        self.control_dt = 1.0 / cfg.control_hz
        self.physics_dt = 1.0 / cfg.physics_hz
        self.max_steps = round(cfg.episode_seconds * cfg.control_hz)
        self.clip_duration = float(self.motion.duration[0])
        self.loop = bool(self.motion.loop[0])
        spec = config.clip.fall_contact
        if spec == "auto":
            spec = default_fall_contact(clip.name)
        try:
            fall_bodies = np.array(character.fall_bodies(spec))
        except ValueError as err:
            raise UserError(f"config key 'clip.fall_contact': {err}") from None
        self.fall_contact = spec
        self.fall_geom = np.isin(self.model.geom_bodyid, fall_bodies)
        self.time = 0.0
        self.steps = 0
        self.root_offset = np.zeros(2)  # the env's info["root_offset"]

    # ---- the env's reset and transition ---------------------------------------------------
    def _kinematics(self, data: mujoco.MjData) -> None:
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)
        mujoco.mj_comVel(self.model, data)

    def _phase(self, t: float) -> np.ndarray:
        return np.asarray(motion_lib.phase(self.motion, 0, np.float32(t), np))

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Reference (qpos, qvel) at clip time t (float32 time, as in the env), root shifted by
        the current root offset."""
        qpos, qvel = motion_lib.sample(self.motion, 0, np.float32(t), np)
        return motion_lib.shift_root(qpos, self.root_offset, np), qvel

    def set_state(self, qpos: Any, qvel: Any, t: float, steps: int = 0, root_offset: Any = (0.0, 0.0)) -> np.ndarray:
        """Put the character in (qpos, qvel) at clip time t; returns the observation."""
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = qpos
        self.data.qvel[:] = qvel
        self._kinematics(self.data)
        self.time = float(np.float32(t))
        self.steps = int(steps)
        self.root_offset = np.array(root_offset, dtype=np.float64)
        return observation(kin_from_data(self.data, np), self._phase(self.time), np)

    def reset_at(self, t: float) -> np.ndarray:
        """The reference state at clip time t (RSI); returns the observation."""
        qpos, qvel = motion_lib.sample(self.motion, 0, np.float32(t), np)
        return self.set_state(qpos, qvel, t)

    def _bad_warnings(self) -> int:
        return sum(int(self.data.warning[w].number) for w in _BAD_WARNINGS)

    def step(self, action: Any) -> Step:
        cfg = self.config.env
        # The env keeps time in float32; so does this, so that both sample the same reference.
        t = float(np.float32(np.float32(self.time) + np.float32(self.control_dt)))
        ref_qpos, ref_qvel = motion_lib.sample(self.motion, 0, np.float32(t), np)  # the unshifted root
        targets = action_to_targets(self.layout, np.asarray(action, np.float64), ref_qpos,
                                    cfg.action_mode, cfg.action_scale, np)
        data = self.data
        warnings0 = self._bad_warnings()
        fell = False
        for _ in range(self.substeps):
            data.qfrc_applied[:] = pd_forces(self.layout, data.qpos, data.qvel, targets, self.physics_dt, np,
                                             cfg.torque_limit)
            mujoco.mj_step(self.model, data)
            n = data.ncon
            if n:
                geom = data.contact.geom[:n]
                hit = (self.fall_geom[geom[:, 0]] | self.fall_geom[geom[:, 1]]) & (data.contact.dist[:n] < 0.0)
                fell = fell or bool(hit.any())
        fell = fell and cfg.early_termination
        self._kinematics(data)
        if self.config.reward.sync_root_position:
            self.root_offset = motion_lib.sync_root_offset(self.motion, 0, np.float32(self.time), np.float32(t),
                                                           self.root_offset, data.qpos[0:2], ref_qpos[0:2], np)
        self._ref.qpos[:] = motion_lib.shift_root(ref_qpos, self.root_offset, np)
        self._ref.qvel[:] = ref_qvel
        self._kinematics(self._ref)
        sim_kin, ref_kin = kin_from_data(data, np), kin_from_data(self._ref, np)
        r, metrics = reward(self.layout, sim_kin, ref_kin, self.config.reward.kind, np)

        finite = bool(np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel)))
        bad = (not finite or bool(np.any(np.abs(data.qvel) > cfg.max_joint_velocity))
               or self._bad_warnings() > warnings0)  # MuJoCo resets a diverged state itself
        self.steps += 1
        self.time = t
        timeout = self.steps >= self.max_steps
        clip_end = (not self.loop) and t >= self.clip_duration - 1e-4
        failed = fell or bad
        done = failed or timeout or clip_end
        r = 0.0 if failed else float(r)
        obs = observation(sim_kin, self._phase(t), np)
        obs = np.zeros_like(obs) if bad else np.nan_to_num(obs)
        out = {k: float(v) for k, v in metrics.items()}
        if bad:
            out = {k: (0.0 if k.startswith("error") else v) for k, v in out.items()}
        out.update(reward=r, fell=float(fell))
        return Step(obs=obs, reward=r, done=done, fell=fell, bad=bad,
                    truncated=timeout and not failed and not clip_end, metrics=out)

    # ---- evaluation (mirrors mjxmimic.runs.evaluate) -------------------------------------------
    @property
    def max_eval_horizon(self) -> int:
        return self.max_steps if self.loop else int(np.ceil(self.clip_duration / self.control_dt))

    def eval_horizon(self, t: float) -> int:
        """Steps of the NR horizon from start time t (EVALUATION.md; as ImitationEnv.eval_horizon),
        at least 1 and at most max_eval_horizon (as mjxmimic.runs.evaluate)."""
        if self.loop:
            h = self.max_steps
        else:
            dur, dt = np.float32(self.clip_duration), np.float32(self.control_dt)
            h = int(np.ceil((dur - np.float32(t)) / dt - np.float32(1e-4)))
        return min(max(h, 1), self.max_eval_horizon)

    def start_times(self, n: int, seed: int) -> np.ndarray:
        """n start times ~ U[0, clip duration) from a seeded numpy generator (the interval that
        mjxmimic.runs.evaluate draws from; its own times come from JAX's generator, see export)."""
        return np.random.default_rng(seed).uniform(0.0, self.clip_duration, size=n).astype(np.float32)

    def episode(self, policy: Callable[[np.ndarray], np.ndarray], t0: float,
                on_step: Callable[[CpuEpisode, Step], Any] | None = None) -> dict[str, Any]:
        """One evaluation episode from the reference state at t0 with the deterministic policy,
        counted as mjxmimic.runs.evaluate counts: it runs to its horizon (the env's time limit does not
        cut it short) unless it fails (a fall, or a done that is not a timeout more than one step
        before the horizon's end: the NaN/exploding-state guard) or the clip ends."""
        obs = self.reset_at(t0)
        horizon = self.eval_horizon(t0)
        total, steps, ok_steps, pose, ee, failed = 0.0, 0, 0, 0.0, 0.0, False
        for k in range(horizon):
            s = self.step(policy(obs))
            steps += 1
            total += s.reward
            ended = s.done and not s.truncated
            failed = s.fell or (ended and k + 2 < horizon)
            if not failed:
                ok_steps += 1
                pose += s.metrics["error/pose"]
                ee += s.metrics["error/end_effector"]
            if on_step is not None and on_step(self, s) is False:
                break
            if failed or ended:
                break
            obs = s.obs
        return {"start_time": float(t0), "horizon": horizon, "steps": steps, "reward": total,
                "nr": total / horizon, "failed": failed, "ok_steps": ok_steps, "pose": pose, "ee": ee}


def summarize(episodes: list[dict[str, Any]], control_dt: float) -> dict[str, Any]:
    """Per-episode sums -> the EVALUATION.md numbers, under mjxmimic.runs.evaluate.summarize's names."""
    ok = max(sum(e["ok_steps"] for e in episodes), 1)
    per_episode = np.array([e["reward"] / e["horizon"] for e in episodes])
    return {
        "nr": float(per_episode.mean()),
        "nr_std": float(per_episode.std()),
        "fall_rate": float(np.mean([e["failed"] for e in episodes])),
        "survival_s": float(np.mean([e["steps"] for e in episodes]) * control_dt),
        "pose_error_rad": float(sum(e["pose"] for e in episodes) / ok),
        "end_effector_error_m": float(sum(e["ee"] for e in episodes) / ok),
        "mean_horizon_steps": float(np.mean([e["horizon"] for e in episodes])),
        "episodes": len(episodes),
    }


def evaluate(env: CpuEpisode, policy: Callable[[np.ndarray], np.ndarray], starts: Any,
             progress: Callable[[int, dict], Any] | None = None,
             on_step: Callable[[CpuEpisode, Step], Any] | None = None) -> dict[str, Any]:
    """Sim-to-sim NR (EVALUATION.md): one episode per start time on the CPU simulator.
    on_step(env, step) after every step (a viewer); returning False ends that episode."""
    t_start = time.perf_counter()
    episodes = []
    for i, t0 in enumerate(np.asarray(starts, np.float32)):
        episodes.append(env.episode(policy, float(t0), on_step=on_step))
        if progress is not None:
            progress(i, episodes[-1])
    wall = time.perf_counter() - t_start
    out = summarize(episodes, env.control_dt)
    steps = sum(e["steps"] for e in episodes)
    out.update(control_steps=steps, eval_seconds=wall, steps_per_s=steps / wall if wall > 0 else None,
               start_times=[e["start_time"] for e in episodes],
               per_episode_nr=[e["nr"] for e in episodes])
    return out
