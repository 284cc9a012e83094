"""`mjxmimic sweep --executor ray`: spec and missing-Ray errors (fast); 2-run sweeps through a local
Ray cluster of CPU trials on the cpu preset, whose reports match the local runner's, one with a
stand-in trainer and one run made to fail, one where ASHA prunes the weaker run, and one of real
training (slow)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from test_sweep import REPO, TINY, report_rows, sweep_both_ways, write_spec

from mjxmimic import cli
from mjxmimic.core.errors import UserError
from mjxmimic.ops import sweep

BAD_RAY = [
    ({"schedular": "asha"}, "unknown field 'schedular'"),
    ({"scheduler": "pbt", "grace_period": 64}, "scheduler 'pbt'"),
    ({"scheduler": "asha"}, "grace_period: required"),
    ({"scheduler": "asha", "grace_period": 0}, "grace_period 0"),
    ({"scheduler": "asha", "grace_period": 64, "metric": "reward"}, "metric 'reward'"),
    ({"scheduler": "asha", "grace_period": 64, "max_t": 32}, "more than max_t 32"),
    ({"scheduler": "asha", "grace_period": 64, "reduction_factor": 1}, "reduction_factor 1"),
    ("asha", "ray: expected an object"),
]


@pytest.mark.parametrize("block,needle", BAD_RAY, ids=[n for _, n in BAD_RAY])
def test_bad_ray_block_is_one_line(tmp_path, block, needle):
    path = write_spec(tmp_path / "bad.json", preset="cpu", ray=block)
    with pytest.raises(UserError) as err:
        sweep.load_spec(path)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ray: ") and needle in msg


def test_ray_block_defaults(tmp_path):
    spec = sweep.load_spec(write_spec(tmp_path / "s.json", preset="cpu", set={"run.total_samples": 4096},
                                      ray={"scheduler": "asha", "grace_period": 512}))
    assert spec.ray == {"scheduler": "asha", "metric": "eval/nr", "grace_period": 512, "max_t": 4096,
                        "reduction_factor": 4}
    assert sweep.load_spec(write_spec(tmp_path / "n.json", preset="cpu")).ray == {}


def test_executor_ray_without_ray_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # as if not installed
    monkeypatch.setitem(sys.modules, "ray.tune", None)
    path = write_spec(tmp_path / "s.json", preset="cpu", out=str(tmp_path / "out"))
    rc = cli.main(["sweep", str(path), "--executor", "ray"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1
    assert err == 'mjxmimic sweep: error: --executor ray needs Ray Tune: pip install -e ".[ray]"\n'
    assert not (tmp_path / "out").exists()


RAY_SWEEP = textwrap.dedent("""
    # the sweep through a local Ray cluster, in a process of its own (as a user's sweep runs)
    import json, sys
    from mjxmimic.ops import sweep
    from mjxmimic.ops.sweep.executors import ray_executor
    spec_path, train = sys.argv[1], sys.argv[2:]
    spec = sweep.load_spec(spec_path)
    executor = ray_executor(spec.out, spec.ray, cpus_per_trial=1)
    results = sweep.Runner(spec, gpus=[], train_command=train or None, echo=print,
                           executor=executor).run()
    sweep.write_report(spec, echo=lambda s: None)
    print(json.dumps(results))
""")


def ray_sweep(spec_path: Path, *train: str, timeout: float = 300) -> dict:
    proc = subprocess.run([sys.executable, "-c", RAY_SWEEP, str(spec_path), *train], check=False, cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_ray_executor_matches_local_runner(tmp_path, monkeypatch):
    """The submitit test's sweep through Ray Tune: one run finishes, the failing one is isolated,
    and the report rows match the local runner's."""
    pytest.importorskip("ray.tune")
    monkeypatch.setenv("PYTHONPATH", str(REPO))

    def through_ray(spec, spec_path, fake):
        results = ray_sweep(spec_path, sys.executable, str(fake))
        assert [p.name for p in (spec.out / "ray").iterdir()]  # went through Tune
        return results

    rows = sweep_both_ways(tmp_path, monkeypatch, "ray", through_ray)
    assert rows["ray"] == rows["local"]


FAKE_EVALS = textwrap.dedent("""
    # Stand-in for `mjxmimic train` with an evaluation every 64 samples (0.4 s apart): NR 0.9 for
    # seed 0; 0.1 for seed 1, which starts 1.5 s after seed 0's first evaluation (so that seed 0 is
    # the first at ASHA's first rung); SIGINT -> a checkpoint, exit 130.
    import json, signal, sys, time
    from pathlib import Path
    args = sys.argv[1:]
    opt = lambda name: args[args.index(name) + 1] if name in args else None
    sets = dict(args[i + 1].split("=", 1) for i, a in enumerate(args) if a == "--set")
    out, seed, step = Path(opt("--out")), int(opt("--seed")), 0
    def on_int(signum, frame):
        (out / "checkpoints" / str(step)).mkdir(parents=True)
        (out / "checkpoints" / str(step) / "_CHECKPOINT_METADATA").write_text("{}")
        sys.exit(130)
    signal.signal(signal.SIGINT, on_int)
    out.mkdir(parents=True)
    from mjxmimic.core import config as c
    c.save(c.make_config(opt("--preset"), {**sets, "clip.name": opt("--clip"), "run.seed": str(seed)}),
           out / "config.json")
    while seed and not (out.parent / "squat-s0" / "metrics.jsonl").exists():
        time.sleep(0.1)
    time.sleep(1.5 * seed)
    total, nr = int(sets["run.total_samples"]), 0.9 - 0.8 * seed
    while step < total:
        time.sleep(0.4)
        step += 64
        with (out / "metrics.jsonl").open("a") as f:
            f.write(json.dumps({"step": step, "wall": 0.4 * step / 64, "eval/nr": nr, "eval/fall_rate": 0.0}) + "\\n")
    (out / "eval.json").write_text(json.dumps({"nr": nr, "fall_rate": 0.0, "samples": step, "reason": "done"}))
""")


@pytest.mark.slow
def test_ray_scheduler_prunes_the_weaker_run(tmp_path, monkeypatch, capsys):
    """ASHA from the spec's ray block: the run that is behind at the first rung is stopped (it
    checkpoints), reported as pruned with its last NR, and left as it is by the next call."""
    pytest.importorskip("ray.tune")
    fake = tmp_path / "fake_evals.py"
    fake.write_text(FAKE_EVALS)
    monkeypatch.setenv("PYTHONPATH", str(REPO))
    spec_path = write_spec(tmp_path / "s.json", preset="cpu", clips=["squat"], seeds=[0, 1],
                           set={"run.total_samples": 1024}, out=str(tmp_path / "out"),
                           ray={"scheduler": "asha", "grace_period": 64, "reduction_factor": 2})
    out = tmp_path / "out"
    assert ray_sweep(spec_path, sys.executable, str(fake)) == {"squat-s0": "finished", "squat-s1": "pruned"}
    assert list((out / "squat-s1" / "checkpoints").iterdir())  # the pruned training checkpointed
    state = json.loads((out / "sweep.json").read_text())["runs"]
    assert state["squat-s1"]["status"] == "pruned" and state["squat-s1"]["exit_code"] == 130
    rows = {r["run"]: r for r in report_rows(out)}
    assert rows["squat-s0"]["status"] == "finished" and float(rows["squat-s0"]["nr"]) == pytest.approx(0.9)
    assert rows["squat-s1"]["status"] == "pruned" and float(rows["squat-s1"]["nr"]) == pytest.approx(0.1)
    assert int(rows["squat-s1"]["nr_at_samples"]) < 1024
    assert "Pruned: stopped early by the Ray Tune scheduler" in (out / "report.md").read_text()
    # again (any executor): nothing to do, the pruned run stays pruned
    assert cli.main(["sweep", str(spec_path), "--dry-run"]) == 0
    printed = capsys.readouterr().out
    assert "(0 to start, 0 to resume, 1 finished, 1 pruned)" in printed
    assert "squat-s1: skip (pruned by the scheduler)" in printed
    lines = []
    assert sweep.Runner(sweep.load_spec(spec_path), gpus=[], echo=lines.append).run() == {
        "squat-s0": "finished", "squat-s1": "pruned"}
    assert "[2/2] squat-s1: pruned already, skipped" in lines


@pytest.mark.slow
def test_ray_sweep_sigterm_checkpoints_every_trial(tmp_path):
    """SIGTERM (or Ctrl-C) to a Ray sweep: Tune stops every trial, each training checkpoints, and
    the runs are recorded interrupted, to be resumed by the next call."""
    pytest.importorskip("ray.tune")
    fake = tmp_path / "fake_evals.py"
    fake.write_text(FAKE_EVALS)
    spec_path = write_spec(tmp_path / "s.json", preset="cpu", clips=["squat"], seeds=[0, 1],
                           set={"run.total_samples": 100_000}, out=str(tmp_path / "out"))
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-c", RAY_SWEEP, str(spec_path), sys.executable, str(fake)], cwd=REPO,
                            env={**os.environ, "PYTHONPATH": str(REPO)}, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT)
    deadline = time.time() + 120
    while not all((out / f"squat-s{s}" / "metrics.jsonl").exists() for s in (0, 1)) and time.time() < deadline:
        time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    printed = proc.communicate(timeout=120)[0].decode()
    assert proc.returncode != 0 and "KeyboardInterrupt" in printed, printed[-3000:]
    state = json.loads((out / "sweep.json").read_text())["runs"]
    assert {(r["status"], r["exit_code"]) for r in state.values()} == {("interrupted", 130)}
    assert all(list((out / f"squat-s{s}" / "checkpoints").iterdir()) for s in (0, 1))
    assert [p.action for p in sweep.plan(sweep.load_spec(spec_path))] == ["resume", "resume"]


@pytest.mark.slow
def test_ray_cpu_sweep_real_training_matches_local(tmp_path, monkeypatch):
    """Real `mjxmimic train` runs (the cpu preset, a tiny budget) through Ray Tune: slow_walk
    trains, a malformed clip fails its run only; the report equals the local runner's."""
    pytest.importorskip("ray.tune")
    monkeypatch.setenv("PYTHONPATH", str(REPO))
    broken = tmp_path / "broken.txt"
    broken.write_text('{"Loop": "wrap", "Frames": [[0.0333, 0.0, 0.9]]}')  # one short frame
    rows, seconds = {}, {}
    for name in ("local", "ray"):
        spec_path = write_spec(tmp_path / f"{name}.json", preset="cpu", clips=["slow_walk", str(broken)], set=TINY,
                               out=str(tmp_path / name))
        t0 = time.time()
        if name == "local":
            assert cli.main(["sweep", str(spec_path), "--gpus", "none"]) == 1
        else:
            assert ray_sweep(spec_path, timeout=600) == {"slow_walk-s0": "finished", "broken-s0": "failed"}
            assert "a clip needs at least two frames" in (tmp_path / name / "logs" / "broken-s0.log").read_text()
        seconds[name] = time.time() - t0
        rows[name] = report_rows(tmp_path / name)
    assert [r["status"] for r in rows["ray"]] == ["finished", "failed (exit 2)"]
    assert rows["ray"] == rows["local"], seconds


def test_trials_sharing_a_gpu_get_their_share_of_its_memory(tmp_path, monkeypatch):
    """Four trials of 0.25 GPU each fit on one GPU: each may take 0.8 / 4 of its memory (JAX's
    default 75 % would leave the others nothing); a whole-GPU trial and a user's own setting are
    left alone."""
    pytest.importorskip("ray.tune")
    from mjxmimic.ops.sweep.ray_executor import RayExecutor

    def trial_env(gpus_per_trial, env):
        executor = RayExecutor(tmp_path, gpus_per_trial=gpus_per_trial)
        monkeypatch.setattr(executor, "_launch", lambda: None)
        executor._thread = object()  # as if Tune were running: start only queues the job
        with (tmp_path / "log").open("wb") as log:
            executor.start(["train"], ["resume"], env, log, tmp_path / "run")
        return executor._feed.queue.get_nowait()["job"]["env"]

    monkeypatch.delenv("XLA_PYTHON_CLIENT_MEM_FRACTION", raising=False)
    assert trial_env(0.25, {"A": "1"})["XLA_PYTHON_CLIENT_MEM_FRACTION"] == "0.20"
    assert "XLA_PYTHON_CLIENT_MEM_FRACTION" not in trial_env(1, {"A": "1"})
    assert "XLA_PYTHON_CLIENT_MEM_FRACTION" not in trial_env(None, {"A": "1"})
    assert trial_env(0.5, {"XLA_PYTHON_CLIENT_MEM_FRACTION": "0.1"})["XLA_PYTHON_CLIENT_MEM_FRACTION"] == "0.1"
