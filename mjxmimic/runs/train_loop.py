"""The training loop: PPO on one run folder, from a fresh start or its latest checkpoint.

What it writes (names from mjxmimic.runs.folder): the resolved config before the first step;
a metrics line per iteration and per evaluation; a checkpoint every run.checkpoint_every
samples, at the end, at run.max_seconds and on Ctrl-C; a checkpoint into RUN/best at every
evaluation that beats the run's best so far (`best_score`: the NR of its reward form, with a task
weighed with the task return; with a push curriculum only once its pushes are full; recorded in
best.json, read back on resume); and at the end (done,
or the target NR reached) eval.json: the final NR evaluation with the run's samples, wall-clock,
steady-state samples/s and time to skill.

run.max_seconds bounds one call (compilation included); the run stops cleanly with a checkpoint
and continues on resume, up to run.total_samples. Time to skill is the wall-clock since the
first call's start (summed over resumed calls, compilation included) when an evaluation first
reached run.target_nr.
"""

from __future__ import annotations

import dataclasses
import errno
import math
import os
import shutil
import signal
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.runs import background, folder
from mjxmimic.runs.progress import Progress

if TYPE_CHECKING:
    from mjxmimic.portable.policy_file import PolicyFile


# a step whose loss is not finite has written NaN into the parameters
NON_FINITE_GUARD = ("ppo/total_loss", "policy/std")


@dataclasses.dataclass
class Outcome:
    """How a call of `train` ended, for the command to report."""

    exit_code: int
    reason: str  # "done", "target", "max_seconds", "interrupted"
    env_steps: int
    iterations: int
    summary: dict
    final_eval: dict | None = None  # what eval.json holds, when this call wrote it
    call_iterations: int = 0  # iterations this call ran (0: it stopped before its first)


class _StopFlag:
    """The first Ctrl-C (SIGINT) or SIGTERM (what schedulers and `timeout` send) asks the loop to
    stop after the current iteration, then checkpoint and exit 130 (143 for SIGTERM); a second
    one interrupts at once. With STOP_WITH_PARENT=1, so does the death of the parent process."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.requested = False
        self.signal = None
        self._previous = {}
        self._parent = os.getppid() if os.environ.get(folder.STOP_WITH_PARENT) == "1" else None

    def should_stop(self) -> bool:
        if not self.requested and self._parent is not None and os.getppid() != self._parent:
            self.requested, self.signal = True, signal.SIGTERM
        return self.requested

    def __enter__(self):
        for sig in self.SIGNALS:
            try:
                self._previous[sig] = signal.signal(sig, self._handle)
            except ValueError:  # not the main thread
                pass
        return self

    def _handle(self, signum, frame):
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        self.signal = signum

    @property
    def exit_code(self) -> int:
        return 143 if self.signal == signal.SIGTERM else 130

    def __exit__(self, *exc):
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)


def _policy_file(config: config_lib.Config, env, params: Any):
    """The policy as an in-memory portable file (for a video of it)."""
    from mjxmimic.portable.policy_file import make_policy_file

    weights = [float(w) for w in env.spec.lib.clip_weight] if len(env.clips) > 1 else None
    return make_policy_file(config, env.character, env.clips, params, weights=weights)


def _device_info() -> dict:
    """The accelerator a run trained on, for its summary (so results name their hardware)."""
    import jax

    devices = jax.local_devices()
    return {"device": f"{len(devices)} x {devices[0].device_kind}", "platform": devices[0].platform,
            "jax": jax.__version__}


def best_score(config: config_lib.Config, result: dict) -> tuple[str, float]:
    """What the best checkpoint maximises: the evaluation of the reward the run trains on. The NR
    (in the run's reward form); with a task, the task's weights over that NR and the task return,
    so that a task-only run keeps its best task policy rather than its best imitation."""
    nr = "nr_paper" if config.reward.kind == "paper" else "nr"
    if not config.task.name:  # a task's evaluation always carries its task_return
        return nr, float(result[nr])
    task = config.task
    return (f"{task.imitation_weight:g} {nr} + {task.task_weight:g} task_return",
            float(task.imitation_weight * result[nr] + task.task_weight * result["task_return"]))


def train(config: config_lib.Config, run_dir: Path, *, resume: bool = False, env=None,
          env_factory: Callable | None = None, start_time: float | None = None,
          progress: bool | str = True, on_iteration: Callable[[int, dict], None] | None = None,
          init_policy: PolicyFile | None = None) -> Outcome:
    """Train (or continue) the run in `run_dir`, holding its writer lock. `env`/`env_factory`
    default to mjxmimic.envs.mjx_env.make_env (tests pass a stand-in). `start_time`: the command's
    start (time-to-skill counts from it). `init_policy`: run.init_from's policy, where the caller has
    read and checked it already (mjxmimic.runs.warm_start.read_start); else it is read here."""
    deadline = _sweep_deadline()  # checked before the run folder is touched
    with folder.writer_lock(run_dir):
        if not resume and folder.holds_run(run_dir):
            raise UserError(f"{run_dir}: already holds a run (continue it with --resume)")
        if resume and (done := _finished(run_dir, config)) is not None:
            return done
        try:
            outcome = _train(config, run_dir, resume=resume, env=env, env_factory=env_factory,
                             start_time=start_time, progress=progress, on_iteration=on_iteration,
                             deadline=deadline, init_policy=init_policy)
        except KeyboardInterrupt:  # a second Ctrl-C: at once
            raise
        except Exception as err:  # wherever it strikes: a checkpoint, an evaluation's best, a log row
            background.wait_for_all()
            if not _disk_full(err):
                raise
            raise _disk_full_error(run_dir, err) from None
        background.wait_for_all()
        return outcome


def _finished(run_dir: Path, config: config_lib.Config) -> Outcome | None:
    """The outcome of a run that already trained its run.total_samples and wrote its final
    evaluation: resuming it builds, compiles and evaluates nothing (an evaluation again would only
    append a second row for the same samples)."""
    from mjxmimic.runs import checkpoint

    final = folder.read_eval(run_dir)
    steps = checkpoint.latest_checkpoint(run_dir)
    if final is None or steps is None or steps < config.run.total_samples or final.get("samples") != steps:
        return None
    return Outcome(exit_code=0, reason="done", env_steps=steps, iterations=int(final.get("iterations", 0)),
                   summary=dict(final), final_eval=dict(final))


def _train(config: config_lib.Config, run_dir: Path, *, resume: bool, env, env_factory: Callable | None,
           start_time: float | None, progress: bool | str,
           on_iteration: Callable[[int, dict], None] | None, deadline: float | None,
           init_policy: PolicyFile | None) -> Outcome:
    t_start = time.time() if start_time is None else start_time
    import jax

    from mjxmimic.runs import checkpoint
    from mjxmimic.runs.evaluate import Evaluator
    from mjxmimic.runs import metrics_log
    from mjxmimic.runs.metrics_log import MetricsLog
    from mjxmimic.learn.ppo import export_params, make_trainer

    if env_factory is None:
        import functools

        from mjxmimic.envs.mjx_env import make_env

        env_factory = functools.partial(make_env, run_dir=run_dir)  # a resume reads the clips the run kept
    if env is None:
        env = env_factory(config)
    trainer = make_trainer(env, config)
    run_cfg = config.run
    graded = config_lib.evaluation_config(config)  # training-only perturbations off (pushes, randomisation)
    eval_env = env_factory(graded) if graded != config else env
    evaluator = Evaluator(eval_env, config, trainer.make_policy)
    # The train step and the env reset compile side by side, from shapes alone (compilation is most
    # of a run's first minute), and training starts once both are done. The evaluator compiles
    # while training starts, except under MuJoCo Warp: there a running program captures CUDA graphs
    # in CUDA's global capture mode, which fails ("Warp CUDA error 901") if another thread
    # meanwhile loads a kernel module (tracing does) or autotunes (compiling does), so the
    # evaluator compiles beside the other two and nothing runs before all three are done. There,
    # too, the three are traced one after the other in this thread before any compiles: Warp names
    # its foreign calls in the order they are first traced, and the compilation cache
    # (mjxmimic.core.compile_cache) finds a program only under the same names.
    under_warp = env.backend == "mjx-warp"
    abstract_params = export_params(trainer.abstract_state)
    lowered = (trainer.lower_train_step(), trainer.lower_reset(), evaluator.lower(abstract_params)) if under_warp \
        else (None, None, None)
    step_compiled = background.in_background(trainer.compile_train_step, lowered[0])
    reset_compiled = background.in_background(trainer.compile_reset, lowered[1])
    if under_warp:
        evaluator.compile(abstract_params, lowered[2])  # here, while the other two compile
    train_step = step_compiled.result()  # compiled once: it cannot recompile
    reset_compiled.result()
    eval_compiled = None if under_warp else background.in_background(evaluator.compile, abstract_params)

    ts = trainer.init(run_cfg.seed)
    meta: dict[str, Any] = {}
    if resume and checkpoint.latest_checkpoint(run_dir) is None:
        # stopped (kill -9) before its first checkpoint: nothing to continue, so start over with
        # its config, dropping what that attempt wrote
        resume = False
        metrics_log.truncate(run_dir, -1)
        folder.best_path(run_dir).unlink(missing_ok=True)
        shutil.rmtree(folder.best_dir(run_dir), ignore_errors=True)
    if resume:
        restored, meta = checkpoint.restore(run_dir, ts)
        # fresh env states (not checkpointed), drawn from the restored key
        restored = restored.replace(env_state=trainer.reset_envs(
            jax.random.fold_in(restored.key, int(meta["env_steps"]) % (2**31))))
        del ts
        ts = trainer.place(restored)
        # rows written after that checkpoint (a crash, kill -9) would repeat its steps
        metrics_log.truncate(run_dir, int(meta["env_steps"]))
    if not resume:
        from mjxmimic.envs.mjx_env import load_env_inputs

        character, clips, weights = load_env_inputs(config, run_dir)  # those kept by a start that never checkpointed
        if config.run.init_from:
            from mjxmimic.runs.warm_start import apply_start, read_start

            init_policy = init_policy or read_start(config, character, [c.name for c in clips])
            ts = trainer.place(apply_start(ts, init_policy, config))
    if not resume or folder.load_config(run_dir) != config:  # a resume may change run.* keys
        folder.write_config(run_dir, config)  # only once the restore (or the start) has succeeded
    if not resume:
        folder.keep_clips(run_dir, clips, weights)
    prior_elapsed = float(meta.get("elapsed_seconds", 0.0))
    env_steps = int(meta.get("env_steps", 0))
    iterations = int(meta.get("iterations", 0))
    iterations_before = iterations
    time_to_skill = meta.get("time_to_skill_s")
    last_eval_steps = int(meta.get("last_eval_steps", 0))
    last_ckpt_steps = env_steps
    spi = trainer.samples_per_iteration

    eval_seed = run_cfg.seed + 1

    def elapsed() -> float:
        return prior_elapsed + time.time() - t_start

    tracker = None
    if run_cfg.wandb_project:
        from mjxmimic.runs.wandb_log import WandbRun

        tracker = WandbRun(run_dir, config)
    log = MetricsLog(run_dir, mirror=tracker)
    state = {"last_eval": None, "steady_samples": 0, "steady_seconds": 0.0, "iter_seconds": 0.0,
             "eval_seconds": 0.0}

    best = folder.read_best(run_dir) if resume else None

    # a policy still short of the full pushes of its curriculum is not yet the push-trained one, a
    # started one (run.init_from) is the source's until it has trained, and run.best_from_samples
    # puts the bound later still
    best_from = max(config.env.push_start_samples + config.env.push_ramp_samples, int(bool(config.run.init_from)),
                    config.run.best_from_samples)

    def keep_if_best(result: dict) -> bool:
        """Checkpoint into RUN/best, then record the evaluation in RUN/best.json (in that order,
        so that best.json never names a checkpoint that is not there); whether it was the best."""
        nonlocal best
        if env_steps < best_from:
            return False
        metric, value = best_score(config, result)
        # the recorded best is scored again: a run resumed under other task weights compares alike
        if best is not None and value <= best_score(config, best["eval"])[1]:
            return False
        checkpoint.save(run_dir, ts, iterations=iterations, elapsed_seconds=elapsed(), best=True,
                        extra={"samples_per_iteration": spi})
        best = {"metric": metric, "value": value, "checkpoint": env_steps,
                "eval": dict(result, seed=eval_seed)}
        folder.write_json_atomic(folder.best_path(run_dir), best)
        return True

    def run_eval() -> dict:
        nonlocal last_eval_steps, time_to_skill
        t = time.time()
        if eval_compiled is not None:
            eval_compiled.result()
        result = evaluator(export_params(ts), eval_seed, samples=env_steps, train_seconds=elapsed())
        improved = keep_if_best(result)
        state["eval_seconds"] = time.time() - t
        last_eval_steps = env_steps
        if run_cfg.target_nr > 0 and time_to_skill is None and result["nr"] >= run_cfg.target_nr:
            time_to_skill = elapsed()
        if time_to_skill is not None:
            result["time_to_skill_s"] = time_to_skill
        log.write(env_steps, elapsed(), {"iteration": iterations,
                                         **{f"eval/{k}": v for k, v in result.items()}})
        if improved and tracker is not None:
            tracker.best_video(env_steps, lambda: _policy_file(config, env, export_params(ts)))
        state["last_eval"] = (env_steps, result)
        return result

    def save_checkpoint() -> None:
        nonlocal last_ckpt_steps
        checkpoint.save(run_dir, ts, iterations=iterations, elapsed_seconds=elapsed(),
                        extra={"last_eval_steps": last_eval_steps, "time_to_skill_s": time_to_skill,
                               "samples_per_iteration": spi})
        last_ckpt_steps = env_steps

    def summary(reason: str) -> dict:
        out = {"reason": reason, "samples": env_steps, "iterations": iterations,
               "train_seconds": elapsed(), "samples_per_iteration": spi,
               "num_envs": config.ppo.num_envs, "unroll_length": config.ppo.unroll_length,
               "physics_hz": config.env.physics_hz, "solver_iterations": config.env.solver_iterations,
               "policy_hidden": list(config.ppo.policy_hidden), **_device_info()}
        if state["steady_seconds"] > 0:
            out["samples_per_s_steady"] = state["steady_samples"] / state["steady_seconds"]
        if time_to_skill is not None:
            out["time_to_skill_s"] = time_to_skill
        return out

    reason = "done"
    non_finite = ""
    final = None
    bar = Progress(progress, run_cfg.total_samples, env_steps)
    next_eval = (last_eval_steps // run_cfg.eval_every + 1) * run_cfg.eval_every
    next_ckpt = (env_steps // run_cfg.checkpoint_every + 1) * run_cfg.checkpoint_every
    first_this_call = True
    stop = _StopFlag()
    try:
        if not resume and run_cfg.eval_at_start and env_steps == 0:
            result = run_eval()
            bar.note(f"{'starting (run.init_from)' if config.run.init_from else 'untrained'} policy: "
                     f"NR {result['nr']:.3f}")
        with stop, bar:
            while env_steps < run_cfg.total_samples:
                if stop.should_stop():
                    reason = "interrupted"
                    break
                now, next_iter = time.time(), state["iter_seconds"]
                if ((run_cfg.max_seconds > 0 and now - t_start + next_iter >= run_cfg.max_seconds)
                        or (deadline is not None and now + next_iter >= deadline)):
                    reason = "max_seconds"
                    break
                t = time.time()
                ts, metrics = train_step(ts)
                metrics = jax.device_get(metrics)
                dt = time.time() - t
                iterations += 1
                env_steps += spi
                if first_this_call:
                    first_this_call = False
                    bar.note(f"first iteration done in {dt:.0f} s; {elapsed() - prior_elapsed:.0f} s "
                             f"since the start (compilation included)")
                else:  # the first iteration's time holds one-off work (graph captures): no guide to the next one's
                    state["iter_seconds"] = dt
                    state["steady_samples"] += spi
                    state["steady_seconds"] += dt
                record = {k: float(v) for k, v in metrics.items()}
                log.write(env_steps, elapsed(), {"iteration": iterations, "samples_per_s": spi / dt, **record})
                bad = [k for k in NON_FINITE_GUARD if not math.isfinite(record.get(k, 0.0))]
                if bad:
                    reason = "non_finite"
                    non_finite = f"{bad[0]} is {record[bad[0]]} at {env_steps:,} samples"
                    break
                bar.update(env_steps, spi / dt, record.get("reward", math.nan))
                if on_iteration is not None:
                    on_iteration(iterations, record)

                if env_steps >= next_eval:
                    next_eval = (env_steps // run_cfg.eval_every + 1) * run_cfg.eval_every
                    result = run_eval()
                    bar.note(f"eval at {env_steps:,} samples: NR {result['nr']:.3f}, "
                             f"fall rate {result['fall_rate']:.2f}")
                    if time_to_skill is not None and run_cfg.target_nr > 0:
                        reason = "target"
                        break
                if env_steps >= next_ckpt:
                    next_ckpt = (env_steps // run_cfg.checkpoint_every + 1) * run_cfg.checkpoint_every
                    save_checkpoint()
    except KeyboardInterrupt:
        reason = "interrupted"
    except Exception:
        log.close()
        raise

    # Everything below also runs after Ctrl-C: the state in `ts` is whole (the step either
    # finished or never started; a donated-but-unassigned state cannot happen with the flag).
    try:
        # (never over the last good checkpoint with parameters that are no longer finite)
        whole = not any(getattr(x, "is_deleted", lambda: False)() for x in jax.tree_util.tree_leaves(ts))
        if whole and reason != "non_finite":
            if last_ckpt_steps != env_steps or checkpoint.latest_checkpoint(run_dir) is None:
                save_checkpoint()
        if reason in ("done", "target"):
            if state["last_eval"] is not None and state["last_eval"][0] == env_steps:
                final = dict(state["last_eval"][1])
            else:
                final = run_eval()
            final.update(summary(reason))
            folder.write_eval(run_dir, final)
        out = summary(reason)
        log.write(env_steps, elapsed(), {"iteration": iterations, **{f"run/{k}": v for k, v in out.items()
                                                                      if isinstance(v, (int, float))}})
    finally:
        log.close()
    if reason == "non_finite":
        raise UserError(f"{run_dir}: training stopped: {non_finite} (the learning rate or the "
                        f"physics diverged); the last good checkpoint, at {last_ckpt_steps:,} samples, is kept")
    exit_code = {"interrupted": stop.exit_code}.get(reason, 0)
    return Outcome(exit_code=exit_code, reason=reason, env_steps=env_steps, iterations=iterations,
                   summary=out, final_eval=final, call_iterations=iterations - iterations_before)


def _sweep_deadline() -> float | None:
    value = os.environ.get(folder.SWEEP_DEADLINE)
    if not value:
        return None
    try:
        return float(value)
    except ValueError:
        raise UserError(f"{folder.SWEEP_DEADLINE}={value!r}: not a time in seconds") from None


def _disk_full(err: BaseException) -> bool:
    """An error that says the disk is full (an OSError, or one a library wraps around it)."""
    return (isinstance(err, OSError) and err.errno == errno.ENOSPC) or "No space left on device" in str(err)


def _disk_full_error(run_dir: Path, err: BaseException) -> UserError:
    """One line: the error's first line (orbax's run to many) and what is left to resume from."""
    from mjxmimic.runs import checkpoint

    first_line = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
    kept = checkpoint.latest_checkpoint(run_dir)
    kept = "no checkpoint was written" if kept is None else f"the last complete checkpoint (at {kept:,} samples) is kept"
    return UserError(f"{run_dir}: the disk is full ({first_line}); training stopped, {kept}: free space, "
                     "then --resume")
