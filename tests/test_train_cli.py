"""`mjxmimic train` / `mjxmimic eval` end to end.

One real training run (the ImitationEnv, cpu preset) through the command line checks the run
folder, the resolved config, learning (NR against the untrained policy, measured by the same
compiled evaluator at 0 samples), checkpoints and eval.json. Resume, max_seconds and Ctrl-C use
the stand-in env through `train()` to stay fast.
"""

import argparse
import json
import os
import signal
from pathlib import Path

import jax
import jax.numpy as jnp
import pytest

from mjxmimic import cli
from mjxmimic.runs import checkpoint
from mjxmimic.core import config as config_lib
from mjxmimic.commands.train import resolve_run
from mjxmimic.core.errors import UserError
from mjxmimic.runs.metrics_log import read
from mjxmimic.runs.train_loop import train
from standin_env import SeesPushScale, StandInEnv

REPO = Path(__file__).resolve().parent.parent

# The real run. Budgets chosen so that learning is clear within about three minutes on 2 cores:
# - the clip is the first 1.5 s of the project's `wave`, played once (Loop "none"): NR's horizon
#   then runs to the clip's end (about 0.75 s on average), so NR measures how well the policy
#   tracks while it stands; on a looping clip NR is the fraction of 20 s survived, which a few
#   hundred thousand samples do not move;
# - env.solver_iterations=4 / ls_iterations=8 (pinned, as when these margins were set): with 1 solver
#   iteration the humanoid is unstable even when PD-tracking the reference exactly (it bounces up
#   to metres within 1-2 s), so nothing can be learned;
# - env.action_mode=absolute (DeepMimic's PD targets): with residual targets the untrained policy
#   (zero residual = the reference pose) already scores NR ~0.98 on this clip, leaving nothing
#   to show; absolute targets start from a poor pose that PPO visibly improves;
# - 64 evaluation episodes at the same start times (same seed) for every evaluation.
REAL_SET = ["run.total_samples=153600", "run.eval_every=76800", "run.checkpoint_every=76800",
            "run.eval_at_start=true", "run.eval_episodes=64", "env.solver_iterations=4",
            "env.ls_iterations=8", "env.physics_hz=120", "env.action_mode=absolute", "env.action_scale=1.0"]


@pytest.fixture(scope="module")
def real_clip(tmp_path_factory) -> str:
    clip = json.loads((REPO / "mjxmimic" / "motion" / "clips" / "wave.txt").read_text())
    clip["Loop"] = "none"
    clip["Frames"] = clip["Frames"][:46]
    path = tmp_path_factory.mktemp("clip") / "wave_once.txt"
    path.write_text(json.dumps(clip))
    return str(path)


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


@pytest.fixture(scope="module")
def real_run(tmp_path_factory, real_clip):
    run_dir = tmp_path_factory.mktemp("real") / "run"
    args = ["train", "--preset", "cpu", "--clip", real_clip, "--out", str(run_dir), "--seed", "3"]
    for item in REAL_SET:
        args += ["--set", item]
    code = cli.main(args)
    assert code == 0
    return run_dir


@pytest.mark.slow
def test_run_folder_and_resolved_config(real_run, real_clip):
    assert (real_run / "config.json").is_file()
    assert (real_run / "metrics.jsonl").is_file()
    assert any((real_run / "tb").iterdir())
    expected = config_lib.make_config("cpu", {"clip.name": real_clip, "run.seed": "3",
                                             **config_lib.parse_set_args(REAL_SET)})
    assert config_lib.load(real_run / "config.json") == expected


@pytest.mark.slow
def test_real_training_beats_the_untrained_policy(real_run):
    evals = [r for r in read(real_run) if "eval/nr" in r]
    assert evals[0]["step"] == 0  # run.eval_at_start: the untrained policy, same evaluator
    untrained = evals[0]["eval/nr"]
    final = json.loads((real_run / "eval.json").read_text())
    assert final["samples"] == 153600
    assert final["nr"] > untrained + 0.04, (untrained, [e["eval/nr"] for e in evals])
    assert final["samples_per_s_steady"] > 0
    assert "(impl jax, cpu)" in final["simulator"]  # the training's own evaluation names its simulator
    for key in ("fall_rate", "survival_s", "pose_error_rad", "end_effector_error_m", "train_seconds"):
        assert key in final


@pytest.mark.slow
def test_checkpoints_of_the_real_run(real_run):
    assert checkpoint.latest_checkpoint(real_run) == 153600
    steps = sorted(int(p.name) for p in (real_run / "checkpoints").iterdir() if p.name.isdigit())
    assert steps == [76800, 153600]  # the last two are kept
    sizes = checkpoint.file_sizes(real_run, 153600)
    assert max(sizes.values()) <= 16 * 1024 * 1024


@pytest.mark.slow
def test_iteration_metrics_lines(real_run):
    lines = [r for r in read(real_run) if "reward" in r and "eval/nr" not in r]
    assert [r["step"] for r in lines] == [512 * (i + 1) for i in range(len(lines))]
    assert lines[-1]["step"] == 153600
    for key in ("wall", "samples_per_s", "reward", "fall_rate", "policy/std", "ppo/v_loss"):
        assert key in lines[-1]


def test_unknown_config_key_is_one_line(capsys, tmp_path):
    code = cli.main(["train", "--preset", "cpu", "--set", "ppo.nope=1", "--out", str(tmp_path / "r")])
    assert code == 2
    assert "ppo.nope" in _one_line_error(capsys)
    assert not (tmp_path / "r").exists()  # nothing half-written


def test_a_run_saved_before_torque_limit_existed_keeps_its_law(tmp_path):
    saved = config_lib.to_dict(config_lib.make_config("cpu"))
    assert config_lib.from_dict(saved).env.torque_limit == "total"
    del saved["env"]["torque_limit"]
    assert config_lib.from_dict(saved).env.torque_limit == "proportional"


@pytest.mark.parametrize("flags, message", [
    (["--clip", "no_such_clip"], "unknown clip 'no_such_clip'"),
    (["--character", "no_such_character"], "unknown character 'no_such_character'"),
])
def test_a_bad_clip_or_character_is_the_only_line(flags, message, capsys, tmp_path):
    """Read before `train` says it builds the env: the error is all it prints, and no folder is made."""
    out = tmp_path / "r"
    assert cli.main(["train", "--preset", "cpu", *flags, "--out", str(out)]) == 2
    assert message in _one_line_error(capsys)
    assert not out.exists()


def test_resume_errors_are_one_line(capsys, tmp_path):
    assert cli.main(["train", "--resume", str(tmp_path / "missing")]) == 2
    assert "run folder not found" in _one_line_error(capsys)
    (tmp_path / "empty").mkdir()
    assert cli.main(["train", "--resume", str(tmp_path / "empty")]) == 2
    assert "not a run folder (no config.json)" in _one_line_error(capsys)


def _standin_config(**run):
    overrides = {"run.total_samples": 5120, "run.eval_every": 2560, "run.checkpoint_every": 2560}
    overrides.update({f"run.{k}": v for k, v in run.items()})
    return config_lib.make_config("cpu", overrides)


def test_resume_continues_from_the_saved_env_steps(tmp_path):
    run_dir = tmp_path / "run"
    first = train(_standin_config(), run_dir, env=StandInEnv(), progress=False)
    assert (first.reason, first.env_steps, first.iterations) == ("done", 5120, 10)
    assert checkpoint.latest_checkpoint(run_dir) == 5120

    more = _standin_config(total_samples=10240)
    second = train(more, run_dir, resume=True, env=StandInEnv(), progress=False)
    assert (second.reason, second.env_steps, second.iterations) == ("done", 10240, 20)
    assert config_lib.load(run_dir / "config.json").run.total_samples == 10240  # run.* may change
    records = read(run_dir)
    steps = [r["step"] for r in records if "reward" in r and "eval/nr" not in r]
    assert steps == [512 * i for i in range(1, 21)]  # continues at 5632, not at 512
    assert [r["iteration"] for r in records if "reward" in r and "eval/nr" not in r] == list(range(1, 21))
    walls = [r["wall"] for r in records]
    assert walls == sorted(walls)  # wall-clock accumulates over calls
    _, meta = checkpoint.restore(run_dir, _template(more))
    assert meta["env_steps"] == 10240 and meta["iterations"] == 20

    def resume_with(*sets):
        return resolve_run(argparse.Namespace(resume=run_dir, overrides=list(sets), clip=None, character=None,
                                              terrain=None, preset=None, out=None, name=None, seed=None))

    config, _, resuming = resume_with("ppo.learning_rate=1e-4")  # a fine-tuning phase
    assert resuming and config.ppo.learning_rate == 1e-4
    config, _, _ = resume_with("ppo.learning_rate_schedule=cosine", "run.total_samples=20480")  # a decay
    assert config.ppo.learning_rate_schedule == "cosine" and config.run.total_samples == 20480
    with pytest.raises(UserError, match="ppo.num_envs"):
        resume_with("ppo.num_envs=8")


def _template(config):
    from mjxmimic.learn.ppo import make_trainer

    return make_trainer(StandInEnv(), config).init(0)


def test_resuming_a_finished_run_evaluates_nothing_again(tmp_path):
    run_dir = tmp_path / "run"
    first = train(_standin_config(), run_dir, env=StandInEnv(), progress=False)
    rows = (run_dir / "metrics.jsonl").read_text()
    again = train(_standin_config(), run_dir, resume=True, env=StandInEnv(), progress=False)
    assert (again.reason, again.env_steps, again.iterations) == ("done", 5120, 10)
    assert again.final_eval["nr"] == first.final_eval["nr"]
    assert (run_dir / "metrics.jsonl").read_text() == rows  # no second evaluation row


def test_max_seconds_stops_with_a_checkpoint_then_resume_finishes(tmp_path):
    import time

    run_dir = tmp_path / "run"
    config = _standin_config(max_seconds=1000.0)
    # pretend the command started just under 1000 s ago: the run must stop at its first check
    first = train(config, run_dir, env=StandInEnv(), progress=False, start_time=time.time() - 999.99)
    assert first.reason == "max_seconds" and first.exit_code == 0
    assert checkpoint.latest_checkpoint(run_dir) == first.env_steps < 5120
    assert not (run_dir / "eval.json").exists()
    second = train(config, run_dir, resume=True, env=StandInEnv(), progress=False)
    assert second.reason == "done" and second.env_steps == 5120
    assert json.loads((run_dir / "eval.json").read_text())["samples"] == 5120


def test_a_sweep_deadline_stops_a_training_that_started_late(tmp_path, monkeypatch):
    """A sweep's budget is one wall-clock deadline: a run that a queue started late stops at it
    with a checkpoint, whatever its own run.max_seconds; a malformed deadline is one line."""
    import time

    from mjxmimic.runs import folder

    monkeypatch.setenv(folder.SWEEP_DEADLINE, f"{time.time() + 0.01:.3f}")
    out = train(_standin_config(max_seconds=1000.0), tmp_path / "run", env=StandInEnv(), progress=False)
    assert out.reason == "max_seconds" and out.env_steps < 5120
    assert checkpoint.latest_checkpoint(tmp_path / "run") == out.env_steps
    monkeypatch.setenv(folder.SWEEP_DEADLINE, "soon")
    with pytest.raises(UserError, match="MJXMIMIC_SWEEP_DEADLINE='soon'"):
        train(_standin_config(), tmp_path / "bad", env=StandInEnv(), progress=False)
    assert not (tmp_path / "bad").exists()


def test_a_slow_first_iteration_does_not_end_the_call_early(tmp_path, monkeypatch):
    """The first iteration of a call carries the compilation (a minute or more when runs share a
    GPU): run.max_seconds must not take it as the time the next iteration needs."""
    import time

    device_get, first = jax.device_get, []

    def slow_first(tree):  # the loop fetches each iteration's metrics (a dict of ppo/... and more) with device_get
        if isinstance(tree, dict) and any(str(k).startswith("ppo/") for k in tree) and not first:
            first.append(time.sleep(10.0))  # as if the first train step had compiled
        return device_get(tree)

    monkeypatch.setattr(jax, "device_get", slow_first)
    # 20 s left at the start: a loop that took the first iteration (10 s and more) for the next
    # one's would stop after it; the other nine take well under the 10 s left (on a busy machine too)
    config = _standin_config(max_seconds=30.0, eval_every=10**9, checkpoint_every=10**9)
    out = train(config, tmp_path / "run", env=StandInEnv(), progress=False, start_time=time.time() - 10.0)
    assert out.reason == "done" and out.iterations == 10, out.reason


@pytest.mark.parametrize("backend", ["mjx-warp", "mjx-jax"])
def test_under_warp_nothing_runs_until_every_compilation_has_finished(tmp_path, monkeypatch, backend):
    """Under MuJoCo Warp a running program captures CUDA graphs, and a capture fails when another
    thread loads kernel modules or autotunes meanwhile (compiling does both): the first program
    that runs (the env reset) waits for the train step's, the reset's and the evaluator's
    compilations; elsewhere the evaluator may still be compiling while training starts. Under
    Warp the three are traced in one order in the main thread first."""
    import threading

    from mjxmimic.learn.ppo import Trainer
    from mjxmimic.runs.evaluate import Evaluator

    events, reset_ran = [], threading.Event()
    compile_step, compile_reset, compile_eval, reset_envs = (
        Trainer.compile_train_step, Trainer.compile_reset, Evaluator.compile, Trainer.reset_envs)
    traced = []

    def tracing(name, method):
        def trace(self, *args):
            traced.append((name, threading.current_thread() is threading.main_thread()))
            return method(self, *args)
        return trace

    for cls, method in ((Trainer, "lower_train_step"), (Trainer, "lower_reset"), (Evaluator, "lower")):
        monkeypatch.setattr(cls, method, tracing(method, getattr(cls, method)))

    def step(self, *lowered):
        out = compile_step(self, *lowered)
        events.append("step compiled")
        return out

    def reset_compile(self, *lowered):
        compile_reset(self, *lowered)
        events.append("reset compiled")

    def evaluator(self, params, *lowered):
        reset_ran.wait(timeout=5.0)  # a compilation that lasts until training starts, if it does
        compile_eval(self, params, *lowered)
        events.append("evaluator compiled")

    def reset(self, key):
        events.append("reset")
        reset_ran.set()
        return reset_envs(self, key)

    monkeypatch.setattr(Trainer, "compile_train_step", step)
    monkeypatch.setattr(Trainer, "compile_reset", reset_compile)
    monkeypatch.setattr(Evaluator, "compile", evaluator)
    monkeypatch.setattr(Trainer, "reset_envs", reset)
    monkeypatch.setattr(StandInEnv, "backend", backend)
    train(_standin_config(), tmp_path / "run", env=StandInEnv(), progress=False)
    before_reset = set(events[:events.index("reset")])
    assert {"step compiled", "reset compiled"} <= before_reset, events
    assert ("evaluator compiled" in before_reset) == (backend == "mjx-warp"), events
    if backend == "mjx-warp":  # traced in one order in the main thread: Warp's call names follow it
        assert traced == [("lower_train_step", True), ("lower_reset", True), ("lower", True)], traced


@pytest.mark.parametrize("watch", [True, False])
def test_a_sweep_training_stops_with_a_checkpoint_when_its_parent_dies(tmp_path, monkeypatch, watch):
    """A sweep's training (MJXMIMIC_STOP_WITH_PARENT=1) whose parent dies, so that it is handed to
    another parent, checkpoints and stops as if terminated; a training started by hand goes on."""
    from mjxmimic.runs import folder

    if watch:
        monkeypatch.setenv(folder.STOP_WITH_PARENT, "1")
    else:
        monkeypatch.delenv(folder.STOP_WITH_PARENT, raising=False)
    parent = os.getppid()
    iterations = []

    def orphaned_after_three(iteration, metrics):
        iterations.append(iteration)
        if iteration == 3:
            monkeypatch.setattr(os, "getppid", lambda: 1)

    out = train(_standin_config(), tmp_path / "run", env=StandInEnv(), progress=False, on_iteration=orphaned_after_three)
    assert parent != 1
    if watch:
        assert (out.reason, out.exit_code, out.env_steps) == ("interrupted", 143, 3 * 512)
        assert checkpoint.latest_checkpoint(tmp_path / "run") == 3 * 512
    else:
        assert out.reason == "done" and iterations == list(range(1, 11))


def test_a_call_whose_time_ran_out_while_compiling_says_how_to_go_on(tmp_path, monkeypatch, capsys):
    """run.max_seconds stays with the run: a call that spent it all compiling would stop again at
    every --resume, so its last line says to lift it."""
    from mjxmimic.envs import mjx_env
    from mjxmimic.runs import train_loop

    def no_iteration(config, run_dir, **kwargs):
        return train_loop.Outcome(exit_code=0, reason="max_seconds", env_steps=0, iterations=0,
                                  summary={"samples": 0, "iterations": 0, "train_seconds": 12.0})

    monkeypatch.setattr(mjx_env, "make_env", lambda config: argparse.Namespace(backend="mjx-jax"))
    monkeypatch.setattr(train_loop, "train", no_iteration)
    assert cli.main(["train", "--preset", "cpu", "--out", str(tmp_path / "run"), "--set", "run.max_seconds=5"]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert "run.max_seconds (5 s) ran out before the first iteration" in line
    assert line.endswith(f"mjxmimic train --resume {tmp_path / 'run'} --set run.max_seconds=0 (no limit)")


def test_a_call_that_stops_or_fails_before_the_evaluator_compiled_waits_for_it(tmp_path, monkeypatch):
    """The evaluator compiles in a thread of its own (off warp): a call stopped by run.max_seconds
    before that finished waits for it, as a compile cut off by the interpreter's exit aborts the
    process (exit 134 after a clean stop)."""
    import threading
    import time

    from mjxmimic.runs.evaluate import Evaluator

    compile_evaluator = Evaluator.compile

    def slow_compile(self, *args):
        time.sleep(8.0)
        return compile_evaluator(self, *args)

    monkeypatch.setattr(Evaluator, "compile", slow_compile)
    config = _standin_config(max_seconds=0.01, eval_at_start=False)
    out = train(config, tmp_path / "run", env=StandInEnv(), progress=False)
    assert out.reason == "max_seconds" and out.exit_code == 0
    assert not any(t.name == "mjxmimic-compile" and t.is_alive() for t in threading.enumerate())

    # so does one that fails meanwhile (here: W&B cannot start), before it reports the error
    from mjxmimic.runs import wandb_log

    def no_login(*args):
        raise UserError("W&B: no API key")

    monkeypatch.setattr(wandb_log, "WandbRun", no_login)
    with pytest.raises(UserError, match="no API key"):
        train(config_lib.apply_overrides(config, {"run.wandb_project": "p"}), tmp_path / "run2",
              env=StandInEnv(), progress=False)
    assert not any(t.name == "mjxmimic-compile" and t.is_alive() for t in threading.enumerate())


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_ctrl_c_or_sigterm_saves_a_checkpoint_and_exits(tmp_path, sig, code):
    """Ctrl-C, and SIGTERM (what schedulers and `timeout` send): a checkpoint, then a resume goes on."""
    run_dir = tmp_path / "run"

    def interrupt(iteration, metrics):
        if iteration == 3:
            os.kill(os.getpid(), sig)

    before = signal.getsignal(sig)
    out = train(_standin_config(), run_dir, env=StandInEnv(), progress=False, on_iteration=interrupt)
    assert out.exit_code == code and out.reason == "interrupted"
    assert out.env_steps == 3 * 512
    assert checkpoint.latest_checkpoint(run_dir) == 3 * 512
    assert not (run_dir / "eval.json").exists()
    assert signal.getsignal(sig) is before  # handler restored
    again = train(_standin_config(), run_dir, resume=True, env=StandInEnv(), progress=False)
    steps = [r["step"] for r in read(run_dir) if "samples_per_s" in r]
    assert again.reason == "done" and steps == [512 * i for i in range(1, 11)]


def test_eval_command_on_a_run(tmp_path, capsys):
    from mjxmimic.runs.evaluate_run import evaluate_run

    run_dir = tmp_path / "run"
    train(_standin_config(), run_dir, env=StandInEnv(), progress=False)
    training_eval = (run_dir / "eval.json").read_text()
    result = evaluate_run(run_dir, episodes=4, env=StandInEnv())
    assert result["episodes"] == 4 and result["samples"] == 5120 and result["checkpoint"] == 5120
    assert json.loads((run_dir / "eval_5120.json").read_text())["nr"] == result["nr"]
    assert (run_dir / "eval.json").read_text() == training_eval  # the training's own stays whole
    assert cli.main(["export", str(run_dir), "--character", "dog3d"]) == 2  # the run moves the humanoid
    assert "moves humanoid, not dog3d" in capsys.readouterr().err
    assert not (run_dir / "policy.npz").exists()


def test_target_nr_stops_and_records_time_to_skill(tmp_path):
    run_dir = tmp_path / "run"
    out = train(_standin_config(target_nr=0.5, total_samples=51200), run_dir, env=StandInEnv(), progress=False)
    assert out.reason == "target" and out.exit_code == 0
    assert out.env_steps < 51200
    final = json.loads((run_dir / "eval.json").read_text())
    assert final["nr"] >= 0.5 and final["samples"] == out.env_steps
    assert 0 < final["time_to_skill_s"] <= final["train_seconds"]
    assert checkpoint.latest_checkpoint(run_dir) == out.env_steps


def test_checkpoint_files_stay_under_16_mb_with_gpu_sized_networks(tmp_path):
    """[1024, 512] policy and value networks on a 227-number observation and 28 actions (the
    humanoid's sizes): params + adam state are about 18 MB, split over files of at most 8 MiB."""
    from mjxmimic.learn.ppo import make_trainer

    env = StandInEnv(n=28, pad_observation_to=227)
    assert (env.observation_size, env.action_size) == (227, 28)
    config = config_lib.make_config("gpu", {"ppo.num_envs": 8, "ppo.num_minibatches": 2})
    trainer = make_trainer(env, config)
    ts = trainer.init(0)
    # trained-looking (incompressible) parameters and adam moments, not init's zeros
    key = iter(jax.random.split(jax.random.PRNGKey(0), 64))
    noisy = lambda tree: jax.tree_util.tree_map(  # noqa: E731
        lambda x: jax.random.normal(next(key), x.shape, x.dtype) if x.dtype == jnp.float32 and x.ndim else x, tree)
    ts = ts.replace(params=noisy(ts.params), optimizer_state=noisy(ts.optimizer_state))
    checkpoint.save(tmp_path, ts, iterations=0, elapsed_seconds=0.0)
    sizes = checkpoint.file_sizes(tmp_path, 0)
    assert max(sizes.values()) <= 16 * 1024 * 1024
    assert sum(sizes.values()) > 15 * 1024 * 1024  # ~3 x 1.55 M float32: the arrays are really there
    restored, meta = checkpoint.restore(tmp_path, trainer.init(1))
    a = restored.params.policy["params"]["hidden_0"]["kernel"]
    b = ts.params.policy["params"]["hidden_0"]["kernel"]
    assert a.shape == (227, 1024) and (a == b).all()
    assert meta["env_steps"] == 0


def test_the_best_evaluation_keeps_its_checkpoint(tmp_path):
    from mjxmimic.runs import folder

    run_dir = tmp_path / "run"
    train(_standin_config(total_samples=5120, eval_every=1024), run_dir, env=StandInEnv(), progress=False)
    first = folder.read_best(run_dir)
    # resumed with a learning rate that wrecks the policy: later evaluations fall below the best
    wreck = config_lib.apply_overrides(_standin_config(total_samples=10240, eval_every=1024),
                                       {"ppo.learning_rate": 0.5})
    train(wreck, run_dir, resume=True, env=StandInEnv(), progress=False)
    evals = [r for r in read(run_dir) if "eval/nr" in r]
    top = max(evals, key=lambda r: r["eval/nr"])
    assert top["step"] <= 5120 and evals[-1]["eval/nr"] < top["eval/nr"] - 0.05, [r["eval/nr"] for r in evals]
    best = folder.read_best(run_dir)
    assert best == first  # compared with the recorded best after the resume, and kept
    assert best["metric"] == "nr" and best["value"] == pytest.approx(top["eval/nr"])
    assert best["checkpoint"] == top["step"] and best["eval"]["nr"] == pytest.approx(top["eval/nr"])
    assert checkpoint.latest_checkpoint(run_dir, best=True) == top["step"]

    assert folder.select_checkpoint(run_dir) == (top["step"], True)
    assert folder.select_checkpoint(run_dir, "latest") == (10240, False)
    assert folder.select_checkpoint(run_dir, "7680") == (7680, False)
    with pytest.raises(UserError, match="kept: 7680, 10240"):
        folder.select_checkpoint(run_dir, "777")
    env = StandInEnv()
    params, meta = folder.load_policy_params(run_dir, env.observation_size, env.action_size, top["step"], best=True)
    assert meta["checkpoint"] == top["step"] and meta["best"]


def test_a_push_curriculum_keeps_no_best_before_its_pushes_are_full(tmp_path):
    """With pushes held back or ramped, the best checkpoint is one trained with the full pushes:
    a policy from before them scores well without pushes and is not the push-trained one."""
    from mjxmimic.runs import folder

    run_dir = tmp_path / "run"
    config = config_lib.apply_overrides(_standin_config(total_samples=5120, eval_every=1024), {
        "env.events": "push", "env.push_force_n": 100, "env.push_start_samples": 2048, "env.push_ramp_samples": 1024,
        "ppo.learning_rate": 0.5})  # a rate that wrecks the policy: its first evaluations score best
    train(config, run_dir, env=SeesPushScale(), env_factory=lambda c: SeesPushScale(), progress=False)
    evals = [r["step"] for r in read(run_dir) if "eval/nr" in r]
    assert evals[:3] == [0, 1024, 2048]  # evaluated before the full pushes too
    nr = {r["step"]: r["eval/nr"] for r in read(run_dir) if "eval/nr" in r}
    assert max(nr, key=nr.get) < 3072, nr
    assert folder.read_best(run_dir)["checkpoint"] >= 3072


def test_run_best_from_samples_keeps_no_best_before_it(tmp_path):
    """run.best_from_samples: the best is taken from that many samples on (a fine-tuning whose
    first evaluations, before it has learnt what it trains for, would score highest)."""
    from mjxmimic.runs import folder

    run_dir = tmp_path / "run"
    config = config_lib.apply_overrides(_standin_config(total_samples=5120, eval_every=1024), {
        "run.best_from_samples": 3072, "ppo.learning_rate": 0.5})  # the first evaluations score best
    train(config, run_dir, env=StandInEnv(), progress=False)
    nr = {r["step"]: r["eval/nr"] for r in read(run_dir) if "eval/nr" in r}
    assert max(nr, key=nr.get) < 3072, nr
    assert folder.read_best(run_dir)["checkpoint"] >= 3072
    with pytest.raises(UserError, match="run.best_from_samples"):
        config_lib.apply_overrides(config, {"run.best_from_samples": 5120})


def test_a_task_run_keeps_the_best_of_what_it_trains_for():
    from mjxmimic.runs.train_loop import best_score

    early = {"nr": 0.78, "nr_paper": 0.76, "task_return": 0.63}
    late = {"nr": 0.53, "nr_paper": 0.54, "task_return": 0.87}
    config = config_lib.make_config("cpu")
    assert best_score(config, early) == ("nr", 0.78)  # imitation alone: the NR
    both = config_lib.apply_overrides(config, {"task.name": "throw"})
    assert best_score(both, early)[1] == pytest.approx(0.7 * 0.78 + 0.3 * 0.63)
    assert best_score(both, early)[1] > best_score(both, late)[1]
    task_only = config_lib.apply_overrides(both, {"task.imitation_weight": 0, "task.task_weight": 1})
    assert best_score(task_only, late) == ("0 nr + 1 task_return", 0.87)
    assert best_score(task_only, late)[1] > best_score(task_only, early)[1]
    paper = config_lib.apply_overrides(config, {"reward.kind": "paper"})
    assert best_score(paper, early) == ("nr_paper", 0.76)


def test_without_a_preset_the_device_chooses_and_says_so(capsys, tmp_path):
    from mjxmimic.commands.train import add_arguments

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    config, _, _ = resolve_run(parser.parse_args(["--out", str(tmp_path / "r")]))
    expected = "gpu" if jax.default_backend() == "gpu" else "cpu"
    assert config == config_lib.make_config(expected)
    assert f"using '{expected}'" in capsys.readouterr().err


def test_version(capsys):
    from mjxmimic import __version__

    with pytest.raises(SystemExit) as stop:
        cli.main(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"mjxmimic {__version__}"


def test_a_run_keeps_its_clip_so_that_it_outlives_the_original(tmp_path):
    """Evaluation, export and resume rebuild the run's env from RUN/clips/: an edited or deleted
    original (or a machine without MJXMIMIC_CLIPS) changes nothing."""
    from mjxmimic.envs.mjx_env import load_env_inputs
    from mjxmimic.motion.clip import ClipError

    original = tmp_path / "mine.txt"
    original.write_text((REPO / "mjxmimic" / "motion" / "clips" / "slow_walk.txt").read_text())
    config = config_lib.apply_overrides(_standin_config(), {"clip.name": str(original)})
    run_dir = tmp_path / "run"
    train(config, run_dir, env=StandInEnv(), progress=False)
    assert (run_dir / "clips" / "mine.txt").read_text() == original.read_text()
    _, before, _ = load_env_inputs(config)
    original.unlink()
    with pytest.raises(ClipError, match="no such clip file"):
        load_env_inputs(config)
    _, kept, weights = load_env_inputs(config, run_dir)
    assert weights is None and [c.name for c in kept] == [c.name for c in before] == ["mine"]
    assert (kept[0].qpos == before[0].qpos).all() and kept[0].path == run_dir / "clips" / "mine.txt"
    (run_dir / "clips" / ".DS_Store").write_text("")  # a hidden file beside it changes nothing
    assert load_env_inputs(config, run_dir)[1][0].path == run_dir / "clips" / "mine.txt"
    (run_dir / "clips" / "mine.txt").unlink()  # an emptied folder is said, not read by name
    with pytest.raises(UserError, match=r"clips: holds 0 files, not the one clip the run trained on"):
        load_env_inputs(config, run_dir)


def test_a_dataset_run_keeps_its_clips_and_weights(tmp_path, monkeypatch):
    from mjxmimic.envs.mjx_env import load_env_inputs

    data = tmp_path / "two.json"
    data.write_text(json.dumps({"clips": [{"clip": "slow_walk", "weight": 2}, "squat"]}))
    config = config_lib.apply_overrides(_standin_config(), {"clip.name": str(data)})
    run_dir = tmp_path / "run"
    train(config, run_dir, env=StandInEnv(), progress=False)
    assert sorted(p.name for p in (run_dir / "clips").iterdir()) == ["kept_dataset.json", "slow_walk.txt", "squat.txt"]
    data.unlink()
    _, clips, weights = load_env_inputs(config, run_dir)
    assert [c.name for c in clips] == ["slow_walk", "squat"] and weights == [2.0, 1.0]
    built_for = []

    def make_env(cfg, max_worlds=None, run_dir=None):
        built_for.append(run_dir)
        return StandInEnv()

    monkeypatch.setattr("mjxmimic.envs.mjx_env.make_env", make_env)
    longer = config_lib.apply_overrides(config, {"run.total_samples": 7680})
    assert train(longer, run_dir, resume=True, progress=False).reason == "done"
    assert built_for and set(built_for) == {run_dir}  # the resume's envs come from the kept clips
