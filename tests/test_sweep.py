"""`mjxmimic sweep`: spec expansion and errors, run bookkeeping with a stand-in trainer (fast), and
one real 2-run sweep on the cpu preset (one run made to fail by a malformed clip file)."""

from __future__ import annotations

import csv
import importlib.util
import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from mjxmimic import cli
from mjxmimic.ops import sweep
from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError

REPO = Path(__file__).resolve().parent.parent


def write_spec(path: Path, **fields) -> Path:
    path.write_text(json.dumps(fields))
    return path


# ---- expansion ----------------------------------------------------------------------------------

def test_expansion_grid_runs_seeds_clips(tmp_path):
    spec = sweep.load_spec(write_spec(
        tmp_path / "s.json", preset="cpu", clips=["slow_walk", "squat"],
        grid={"env.action_mode": ["absolute", "residual"], "ppo.learning_rate": [1e-3, 3e-4, 1e-4]},
        runs=[{"ppo.num_envs": 16}, {"ppo.num_envs": 64, "ppo.num_minibatches": 8}],
        seeds=[0, 7], set={"run.total_samples": 4096}))
    assert spec.name == "s" and spec.out == Path("runs/sweeps/s")
    assert len(spec.runs) == 2 * (2 * 3) * 2 * 2
    names = [r.name for r in spec.runs]
    assert len(set(names)) == len(names)
    assert all(re.fullmatch(r"[A-Za-z0-9._=+-]+", n) for n in names)
    assert spec.varying_keys == ["env.action_mode", "ppo.learning_rate", "ppo.num_envs", "ppo.num_minibatches"]
    # seeds outermost in execution order; every combination exactly once
    assert [r.seed for r in spec.runs[:24]] == [0] * 24
    combos = {(r.clip, r.config.env.action_mode, r.config.ppo.learning_rate, r.config.ppo.num_envs, r.seed)
              for r in spec.runs}
    assert len(combos) == 48
    run = next(r for r in spec.runs if r.clip == "squat" and r.seed == 7 and r.config.ppo.num_envs == 64
               and r.config.env.action_mode == "residual" and r.config.ppo.learning_rate == 3e-4)
    assert run.name == "squat-action_mode=residual-learning_rate=0.0003-num_envs=64-num_minibatches=8-s7"
    cfg = run.config
    assert (cfg.clip.name, cfg.run.seed, cfg.run.total_samples, cfg.ppo.num_minibatches) == ("squat", 7, 4096, 8)
    assert cfg.ppo.policy_hidden == (64, 64)  # the cpu preset underneath
    assert run.overrides == {"env.action_mode": "residual", "ppo.learning_rate": 3e-4,
                             "ppo.num_envs": 64, "ppo.num_minibatches": 8}
    # the strings the subprocess gets parse back to the same config
    again = config_lib.make_config("cpu", {**run.args, "clip.name": run.clip, "run.seed": str(run.seed)})
    assert again == cfg
    # deterministic
    assert [r.name for r in sweep.load_spec(tmp_path / "s.json").runs] == names


def test_defaults_and_names(tmp_path):
    spec = sweep.load_spec(write_spec(tmp_path / "plain.json", preset="cpu"))
    assert [r.name for r in spec.runs] == ["slow_walk-s0"] and spec.runs[0].config.clip.name == "slow_walk"
    # clips given by path; same stem in two folders -> distinct names with a short hash
    for d in ("a", "b"):
        (tmp_path / d).mkdir()
        (tmp_path / d / "move.txt").write_text("{}")
    spec = sweep.load_spec(write_spec(
        tmp_path / "p.json", preset="cpu", clips=[str(tmp_path / "a/move.txt"), str(tmp_path / "b/move.txt")],
        grid={"ppo.policy_hidden": [[32, 32], [128]]}, seeds=3, out=str(tmp_path / "o")))
    names = [r.name for r in spec.runs]
    assert len(set(names)) == 4 and all(n.startswith("move-policy_hidden=") for n in names)
    assert any(n.startswith("move-policy_hidden=32x32-s3-") for n in names)
    assert {r.config.ppo.policy_hidden for r in spec.runs} == {(32, 32), (128,)}
    assert spec.out == tmp_path / "o"


def test_a_labelled_runs_entry_is_named_by_its_label(tmp_path):
    spec = sweep.load_spec(write_spec(
        tmp_path / "l.json", preset="cpu", grid={"ppo.learning_rate": [1e-3]},
        runs=[{"label": "pushes", "env.events": "push", "env.push_force_max_n": 300}, {"label": "plain"},
              {"ppo.num_envs": 64}]))
    assert [r.name for r in spec.runs] == ["slow_walk-learning_rate=0.001-pushes-s0",
                                           "slow_walk-learning_rate=0.001-plain-s0",
                                           "slow_walk-learning_rate=0.001-num_envs=64-s0"]
    assert spec.runs[0].config.env.push_force_max_n == 300 and spec.runs[1].config.env.events == ""
    assert "label" not in spec.runs[0].args and "label" not in spec.varying_keys


def test_every_shipped_spec_is_valid():
    paths = sorted((REPO / "experiments/sweeps").glob("*.json"))
    assert len(paths) >= 5
    for path in paths:
        spec = sweep.load_spec(path, check_clips=False)
        assert spec.runs and len({r.name for r in spec.runs}) == len(spec.runs), path.name


BAD_SPECS = [
    ({"preset": "cpu", "grid": {"ppo.learnin_rate": [1e-3]}}, "ppo.learnin_rate"),
    ({"preset": "cpu", "set": {"env.nosuch": 1}}, "env.nosuch"),
    ({"preset": "cpu", "runs": [{"ppo.learning_rate": "fast"}]}, "ppo.learning_rate"),
    ({"preset": "cpu", "grid": {"ppo.num_envs": [2.5]}}, "ppo.num_envs"),
    ({"preset": "cpu", "grid": {"env.action_mode": ["sideways"]}}, "env.action_mode"),
    ({"preset": "cpu", "grid": {"ppo.num_envs": [6]}}, "ppo.num_minibatches"),  # cross-key check
    ({"preset": "cpu", "grid": {}}, "grid is empty"),
    ({"preset": "cpu", "grid": {"ppo.num_envs": []}}, "ppo.num_envs"),
    ({"preset": "cpu", "grid": {"ppo.learning_rate": [1e-3]}, "set": {"ppo.learning_rate": 1e-4}},
     "ppo.learning_rate"),
    ({"preset": "cpu", "runs": [{"clip.name": "squat"}]}, "clip.name"),
    ({"preset": "cpu", "set": {"run.seed": 3}}, "run.seed"),
    ({"preset": "cpu", "runs": [{}, {}]}, "comes twice"),
    ({"preset": "cpu", "seeds": []}, "seeds"),
    ({"preset": "cpu", "clips": ["no_such_clip"]}, "no_such_clip"),
    ({"preset": "tpu"}, "tpu"),
    ({"preset": "cpu", "gird": {"ppo.num_envs": [8]}}, "gird"),
    ({"preset": "cpu", "set": {"ppo.num_envs": {"a": 1}}}, "ppo.num_envs"),
    ([1, 2], "JSON object"),
    ({"preset": "cpu", "runs": [{"label": "a b"}]}, '"label"'),
    ({"preset": "cpu", "runs": [{"label": 3}]}, '"label"'),
    ({"preset": "cpu", "runs": [{"label": "x"}, {"label": "x", "ppo.num_envs": 64}]}, '"label"'),
    ({"preset": "cpu", "runs": [{"env.observations": "phase,nope"}]}, "env.observations"),  # a term name
    ({"preset": "cpu", "grid": {"reward.weights": ["pose=1", "posture=1"]}}, "no term 'posture'"),
]


@pytest.mark.parametrize("data,needle", BAD_SPECS, ids=[n for _, n in BAD_SPECS])
def test_bad_spec_is_one_line_naming_file_and_key(tmp_path, data, needle):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(UserError) as err:
        sweep.load_spec(path)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(path)) and needle in msg


def test_bad_spec_files(tmp_path, capsys):
    with pytest.raises(UserError, match="missing.json: sweep spec not found"):
        sweep.load_spec(tmp_path / "missing.json")
    (tmp_path / "broken.json").write_text('{"preset": "cpu", grid: 1}')
    with pytest.raises(UserError, match=r"broken.json: not valid JSON \(.* at line 1\)"):
        sweep.load_spec(tmp_path / "broken.json")
    # through the command line: exit 2, one line on stderr, nothing written
    rc = cli.main(["sweep", str(tmp_path / "broken.json")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and err.startswith("mjxmimic sweep: error: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.json"]


@pytest.mark.parametrize("option, value, message", [
    ("--time-limit", "0", "0: must be at least 1"), ("--runs-per-gpu", "0", "0: must be at least 1"),
    ("--max-jobs", "x", "'x' is not an integer"), ("--gpus-per-trial", "-1", "-1: must be at least 0"),
    ("--max-seconds", "nan", "nan: must be at least 0"),
])
def test_executor_options_are_refused_by_the_dry_run_too(option, value, message, capsys):
    # the dry run used to accept what the sweep itself then refused (or, as nan, passed on)
    with pytest.raises(SystemExit) as exit_:
        cli.main(["sweep", str(REPO / "experiments/sweeps/laptop.json"), "--dry-run", option, value])
    assert exit_.value.code == 2
    assert capsys.readouterr().err.strip().endswith(f"argument {option}: {message}")


def test_example_spec_is_valid():
    spec = sweep.load_spec(REPO / "experiments/sweeps/walk_action_mode.json", check_clips=False)
    assert [r.config.env.action_mode for r in spec.runs] == ["absolute", "residual"]
    assert all(r.config.clip.name == "walk" and r.seed == 0 for r in spec.runs)
    assert all(r.config.run.max_seconds > 0 for r in spec.runs)
    assert all(r.config.ppo.num_envs == config_lib.make_config("gpu").ppo.num_envs for r in spec.runs)


# ---- bookkeeping without training ----------------------------------------------------------------

def fake_checkpoint(run_dir: Path, steps: int) -> None:
    (run_dir / "checkpoints" / str(steps)).mkdir(parents=True)
    (run_dir / "checkpoints" / str(steps) / "_CHECKPOINT_METADATA").write_text("{}")


def test_plan_and_train_args(tmp_path, capsys):
    path = write_spec(tmp_path / "s.json", preset="cpu", grid={"env.action_mode": ["absolute", "residual"]},
                      seeds=[0, 1], set={"run.total_samples": 2048, "run.max_seconds": 30},
                      out=str(tmp_path / "out"))
    spec = sweep.load_spec(path)
    a0, r0, a1, r1 = (spec.runs[i] for i in (0, 1, 2, 3))
    assert [a0.name, r0.name, a1.name] == ["slow_walk-action_mode=absolute-s0", "slow_walk-action_mode=residual-s0",
                                            "slow_walk-action_mode=absolute-s1"]
    # a0 finished; r0 stopped with a checkpoint and a periodic eval; a1 half-written; r1 new
    for run in (a0, r0, a1):
        spec.run_dir(run).mkdir(parents=True)
        config_lib.save(run.config, spec.run_dir(run) / "config.json")
    (spec.run_dir(a0) / "eval.json").write_text(json.dumps(
        {"nr": 0.61, "fall_rate": 0.25, "samples": 2048, "train_seconds": 99.0, "samples_per_s_steady": 1234.5,
         "reason": "done", "device": "1 x cpu"}))
    fake_checkpoint(spec.run_dir(a0), 2048)
    fake_checkpoint(spec.run_dir(r0), 1024)
    (spec.run_dir(r0) / "metrics.jsonl").write_text("\n".join(json.dumps(m) for m in [
        {"step": 512, "wall": 10.0, "reward": 0.3}, {"step": 512, "wall": 11.0, "eval/nr": 0.2, "eval/fall_rate": 1.0},
        {"step": 1024, "wall": 20.0, "reward": 0.4}, {"step": 1024, "wall": 20.5, "run/samples_per_s_steady": 99.0},
    ]) + "\n")
    plans = {p.run.name: p for p in sweep.plan(spec)}
    assert [plans[r.name].action for r in (a0, r0, a1, r1)] == ["skip", "resume", "start", "start"]

    start = sweep.train_args(spec, plans[r1.name])
    assert start[:8] == ["--out", str(spec.run_dir(r1)), "--preset", "cpu", "--clip", "slow_walk", "--seed", "1"]
    assert "env.action_mode=residual" in start and "run.max_seconds=30" in start
    resume = sweep.train_args(spec, plans[r0.name])
    assert resume[:2] == ["--resume", str(spec.run_dir(r0))]
    sets = [resume[i + 1] for i, a in enumerate(resume) if a == "--set"]
    assert all(s.startswith("run.") for s in sets) and "run.total_samples=2048" in sets
    assert not any(s.startswith("run.seed") for s in sets)
    # a sweep budget bounds run.max_seconds
    assert "run.max_seconds=20" in sweep.train_args(spec, plans[r0.name], max_seconds=20.4)

    # raising the budget in the spec turns the finished run into one to resume
    spec2 = sweep.load_spec(write_spec(tmp_path / "s2.json", **{**json.loads(path.read_text()),
                                                                 "set": {"run.total_samples": 4096}}))
    assert sweep.plan(spec2)[0].action == "resume"
    # a folder holding a different config is an error before anything runs
    bad = json.loads(path.read_text())
    bad["set"] = {**bad["set"], "ppo.learning_rate": 0.01}
    with pytest.raises(UserError, match=r"holds a different config \(ppo.learning_rate is 0.001 there, 0.01"):
        sweep.plan(sweep.load_spec(write_spec(tmp_path / "s3.json", **bad)))

    # --dry-run prints the plan and writes nothing
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    assert cli.main(["sweep", str(path), "--dry-run", "--gpus", "none"]) == 0
    out = capsys.readouterr().out
    assert "4 runs" in out and "1 to resume, 1 finished" in out
    assert f"{a0.name}: skip (finished)" in out and f"{r0.name}: resume" in out
    assert f"mjxmimic train --out {spec.run_dir(r1)} --preset cpu --clip slow_walk --seed 1" in out
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before
    # --only picks runs by name pattern; a pattern that matches none is one line naming the runs
    assert cli.main(["sweep", str(path), "--dry-run", "--gpus", "none", "--only", "*-s1"]) == 0
    out = capsys.readouterr().out
    assert "2 runs" in out and f"{r1.name}: start" in out and r0.name not in out
    assert cli.main(["sweep", str(path), "--dry-run", "--only", "run-*,nothing"]) == 2
    assert f"--only run-*,nothing: matches none of the runs of {path} ({a0.name}," in capsys.readouterr().err

    # report from the folders alone: finished row from eval.json, stopped row from metrics.jsonl
    state = {"runs": {r0.name: {"status": "stopped"}, a1.name: {"status": "failed", "exit_code": -9,
                                                              "log_tail": ["Killed"], "log": "logs/x.log"}}}
    md, csv_path = sweep.write_tables(spec, state)
    rows = {r["run"]: r for r in csv.DictReader(csv_path.open())}
    assert list(rows) == [a0.name, a1.name, r0.name, r1.name]  # config-major order, seeds together
    assert rows[a0.name]["status"] == "finished" and float(rows[a0.name]["nr"]) == 0.61
    assert rows[a0.name]["env.action_mode"] == "absolute" and rows[a0.name]["samples_per_s"] == "1234.5"
    assert rows[r0.name]["status"] == "stopped" and float(rows[r0.name]["nr"]) == 0.2
    assert rows[r0.name]["nr_at_samples"] == "512" and rows[r0.name]["samples"] == "1024"
    assert rows[r0.name]["samples_per_s"] == "99.0"
    assert rows[a1.name]["status"] == "failed (signal 9)" and rows[a1.name]["nr"] == ""
    assert rows[r1.name]["status"] == "pending"
    text = md.read_text()
    assert "| `env.action_mode` |" in text and "| 0.610 | 0.25 |" in text and "Device: 1 x cpu." in text
    assert f"`{a1.name}`: failed (signal 9): `Killed`" in text


def test_curves_png_or_clear_note(tmp_path, monkeypatch):
    spec = sweep.load_spec(write_spec(tmp_path / "s.json", preset="cpu", out=str(tmp_path / "out"),
                                      grid={"ppo.learning_rate": [1e-3, 1e-4]}))
    for k, run in enumerate(spec.runs):
        spec.run_dir(run).mkdir(parents=True)
        (spec.run_dir(run) / "metrics.jsonl").write_text("\n".join(json.dumps(m) for m in [
            {"step": 0, "wall": 5.0, "eval/nr": 0.1}, {"step": 64, "wall": 6.0, "reward": 0.2 + k},
            {"step": 128, "wall": 7.0, "reward": 0.3}, {"step": 128, "wall": 8.0, "eval/nr": 0.3 + 0.1 * k}]) + "\n")
    notes = []
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # as if not installed
    paths = sweep.write_report(spec, echo=notes.append)
    assert [p.name for p in paths] == ["report.md", "report.csv"]
    assert notes == ["note: matplotlib is not installed, so no curves.png (pip install matplotlib)"]
    monkeypatch.undo()
    pytest.importorskip("matplotlib")
    paths = sweep.write_report(spec, echo=notes.append)
    png = spec.out / "curves.png"
    assert png in paths and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_detect_gpus(monkeypatch):
    monkeypatch.delenv(sweep.GPU_ENV_VAR, raising=False)
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "2,5")
    assert sweep.detect_gpus() == ["2", "5"]
    assert sweep.detect_gpus("1") == ["2"]
    assert sweep.detect_gpus("none") == [] and sweep.detect_gpus("0") == []
    assert sweep.detect_gpus("0,3") == ["0", "3"]
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "")
    assert sweep.detect_gpus() == []
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "1,-1,2")
    assert sweep.detect_gpus() == ["1"]
    monkeypatch.setenv(sweep.GPU_ENV_VAR, "none")
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "0,1")
    assert sweep.detect_gpus() == []
    with pytest.raises(UserError, match="--gpus 'many'"):
        sweep.detect_gpus("many")


FAKE_TRAIN = textwrap.dedent("""
    # Stand-in for `mjxmimic train`: logs how it was called, fails for a clip named *fail*,
    # else sleeps FAKE_SLEEP seconds and writes a finished run folder; SIGINT -> exit 130.
    import json, os, signal, sys, time
    from pathlib import Path
    args = sys.argv[1:]
    opt = lambda name: args[args.index(name) + 1] if name in args else None
    sets = dict(args[i + 1].split("=", 1) for i, a in enumerate(args) if a == "--set")
    out = Path(opt("--out") or opt("--resume"))
    def on_int(signum, frame):
        Path(os.environ["FAKE_LOG"] + ".sigint").write_text(out.name)
        sys.exit(130)
    signal.signal(signal.SIGINT, on_int)
    with open(os.environ["FAKE_LOG"], "a") as f:
        f.write(json.dumps({"run": out.name, "gpu": os.environ.get("CUDA_VISIBLE_DEVICES"), "t": time.time(),
                            "mem": os.environ.get("XLA_PYTHON_CLIENT_MEM_FRACTION"), "args": args,
                            "deadline": os.environ.get("MJXMIMIC_SWEEP_DEADLINE"),
                            "stop_with_parent": os.environ.get("MJXMIMIC_STOP_WITH_PARENT")}) + "\\n")
    if "fail" in (opt("--clip") or ""):
        print("step 1", flush=True)
        print("boom: made to fail", flush=True)
        sys.exit(3)
    time.sleep(float(os.environ.get("FAKE_SLEEP", "1")))
    out.mkdir(parents=True, exist_ok=True)
    from mjxmimic.core import config as c
    c.save(c.make_config(opt("--preset"), {**sets, "clip.name": opt("--clip"), "run.seed": opt("--seed")}),
           out / "config.json")
    (out / "metrics.jsonl").write_text(json.dumps({"step": 64, "wall": 1.0, "eval/nr": 0.5}) + "\\n")
    (out / "eval.json").write_text(json.dumps({"nr": 0.5, "fall_rate": 0.25, "samples": int(sets["run.total_samples"]),
                                               "train_seconds": 1.0, "reason": "done"}))
    print("done", flush=True)
""")


def test_parallel_runs_one_per_gpu_and_failure_isolation(tmp_path, monkeypatch):
    fake = tmp_path / "fake_train.py"
    fake.write_text(FAKE_TRAIN)
    (tmp_path / "fail.txt").write_text("{}")
    monkeypatch.setenv("FAKE_LOG", str(tmp_path / "calls.jsonl"))
    monkeypatch.setenv("FAKE_SLEEP", "1.5")
    spec = sweep.load_spec(write_spec(tmp_path / "s.json", preset="cpu", clips=["squat", str(tmp_path / "fail.txt")],
                                      seeds=[0, 1, 2], set={"run.total_samples": 256}, out=str(tmp_path / "out")))
    lines = []
    results = sweep.Runner(spec, gpus=["0", "1"], train_command=[sys.executable, str(fake)],
                           echo=lines.append).run()
    ok = [r.name for r in spec.runs if r.clip == "squat"]
    bad = [r.name for r in spec.runs if r.clip != "squat"]
    assert {results[n] for n in ok} == {"finished"} and {results[n] for n in bad} == {"failed"}
    calls = [json.loads(line) for line in (tmp_path / "calls.jsonl").read_text().splitlines()]
    assert sorted(c["run"] for c in calls) == sorted(ok + bad)
    assert {c["gpu"] for c in calls} == {"0", "1"}
    # two at a time: the three 1.5 s runs overlap
    starts = sorted(c["t"] for c in calls if c["run"] in ok)
    assert starts[1] - starts[0] < 1.4
    state = json.loads((spec.out / "sweep.json").read_text())
    rec = state["runs"][bad[0]]
    assert rec["status"] == "failed" and rec["exit_code"] == 3 and rec["log_tail"][-1] == "boom: made to fail"
    assert any(f"{bad[0]}: failed (exit 3)" in line and "boom: made to fail" in line for line in lines)
    assert (spec.out / "logs" / f"{bad[0]}.log").read_text().count("== attempt 1") == 1
    # again: finished runs skipped, failed ones retried (attempt 2)
    (tmp_path / "calls.jsonl").unlink()
    sweep.Runner(spec, gpus=[], train_command=[sys.executable, str(fake)], echo=lines.append).run()
    calls = [json.loads(line) for line in (tmp_path / "calls.jsonl").read_text().splitlines()]
    assert sorted(c["run"] for c in calls) == sorted(bad)
    assert {c["gpu"] for c in calls} == {os.environ.get("CUDA_VISIBLE_DEVICES")}  # sequential, unpinned
    state = json.loads((spec.out / "sweep.json").read_text())
    assert state["runs"][bad[0]]["attempts"] == 2 and state["runs"][ok[0]]["attempts"] == 1


def test_sigterm_checkpoints_running_training(tmp_path):
    """SIGTERM (or Ctrl-C) to the sweep: one SIGINT to the running training, recorded interrupted."""
    fake = tmp_path / "fake_train.py"
    fake.write_text(FAKE_TRAIN)
    spec_path = write_spec(tmp_path / "s.json", preset="cpu", seeds=[0, 1], out=str(tmp_path / "out"))
    driver = tmp_path / "driver.py"
    driver.write_text(textwrap.dedent(f"""
        import sys
        from mjxmimic.ops import sweep
        spec = sweep.load_spec({str(spec_path)!r})
        sweep.Runner(spec, gpus=[], train_command=[sys.executable, {str(fake)!r}]).run()
    """))
    log = tmp_path / "calls.jsonl"
    env = {**os.environ, "FAKE_LOG": str(log), "FAKE_SLEEP": "60", "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen([sys.executable, str(driver)], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    deadline = time.time() + 60
    while not log.exists() and time.time() < deadline:
        time.sleep(0.1)
    assert log.exists(), proc.communicate()[0]
    proc.send_signal(signal.SIGTERM)
    out = proc.communicate(timeout=60)[0].decode()
    assert proc.returncode != 0 and "KeyboardInterrupt" in out
    assert (tmp_path / "calls.jsonl.sigint").read_text() == "slow_walk-s0"
    state = json.loads((tmp_path / "out" / "sweep.json").read_text())
    assert state["runs"]["slow_walk-s0"]["status"] == "interrupted"
    assert state["runs"]["slow_walk-s0"]["exit_code"] == 130
    assert state["runs"]["slow_walk-s1"]["status"] == "pending"
    assert len(log.read_text().splitlines()) == 1  # the second run never started


# ---- a real sweep on the cpu preset --------------------------------------------------------------

TINY = {"run.total_samples": 1024, "ppo.num_envs": 8, "ppo.unroll_length": 4, "ppo.num_minibatches": 2,
        "run.eval_episodes": 2, "env.episode_seconds": 1, "env.physics_hz": 30}


@pytest.mark.slow
def test_cpu_sweep_failure_report_and_rerun(tmp_path, capsys, monkeypatch):
    """Two runs: slow_walk trains to its (tiny) budget; a malformed clip file passes the spec check
    (it exists) and fails its run only. Re-running skips the finished run. With wandb installed,
    the runs also log to W&B (offline)."""
    broken = tmp_path / "broken.txt"
    broken.write_text('{"Loop": "wrap", "Frames": [[0.0333, 0.0, 0.9]]}')  # one short frame
    spec_path = write_spec(tmp_path / "tiny.json", preset="cpu", clips=["slow_walk", str(broken)], set=TINY,
                           out=str(tmp_path / "out"))
    out = tmp_path / "out"
    t0 = time.time()
    tracked = importlib.util.find_spec("wandb") is not None
    monkeypatch.setenv("WANDB_MODE", "offline")
    rc = cli.main(["sweep", str(spec_path), "--gpus", "none", *(["--wandb", "mjxmimic-test"] if tracked else [])])
    first = time.time() - t0
    printed = capsys.readouterr().out
    assert rc == 1, printed
    assert "slow_walk-s0: finished" in printed and "broken-s0: failed (exit 2)" in printed
    assert "a clip needs at least two frames" in printed
    good = out / "slow_walk-s0"
    final = json.loads((good / "eval.json").read_text())
    assert final["samples"] >= 1024 and 0.0 <= final["nr"] <= 1.0
    assert not (out / "broken-s0").exists()  # train writes nothing for a bad clip
    if tracked:
        run_id = json.loads((good / "wandb.json").read_text())["id"]
        assert [r.name.endswith(run_id) for r in (good / "wandb").glob("offline-run-*")] == [True]
    state = json.loads((out / "sweep.json").read_text())
    assert state["runs"]["slow_walk-s0"]["status"] == "finished"
    assert state["runs"]["broken-s0"]["status"] == "failed" and state["runs"]["broken-s0"]["exit_code"] == 2

    rows = {r["run"]: r for r in csv.DictReader((out / "report.csv").open())}
    assert list(rows) == ["slow_walk-s0", "broken-s0"]
    assert rows["slow_walk-s0"]["status"] == "finished"
    assert float(rows["slow_walk-s0"]["nr"]) == pytest.approx(final["nr"])
    assert int(rows["slow_walk-s0"]["samples"]) == final["samples"]
    assert float(rows["slow_walk-s0"]["samples_per_s"]) > 0 and float(rows["slow_walk-s0"]["wall_s"]) > 0
    assert rows["broken-s0"]["status"] == "failed (exit 2)" and rows["broken-s0"]["nr"] == ""
    md = (out / "report.md").read_text()
    assert "| slow_walk-s0 |" in md and "| broken-s0 |" in md and "failed (exit 2)" in md
    try:
        import matplotlib  # noqa: F401
        assert (out / "curves.png").is_file()
    except ImportError:
        assert "no curves.png" in printed

    # --report alone rewrites the tables
    (out / "report.md").unlink()
    assert cli.main(["sweep", str(spec_path), "--report"]) == 0
    assert "| slow_walk-s0 |" in (out / "report.md").read_text()
    capsys.readouterr()

    # again: the finished run is skipped (not retrained), the failed one retried
    mtime = (good / "metrics.jsonl").stat().st_mtime_ns
    t0 = time.time()
    rc = cli.main(["sweep", str(spec_path), "--gpus", "none"])
    second = time.time() - t0
    printed = capsys.readouterr().out
    assert rc == 1
    assert "slow_walk-s0: finished already, skipped" in printed and "broken-s0: failed (exit 2)" in printed
    assert (good / "metrics.jsonl").stat().st_mtime_ns == mtime
    state = json.loads((out / "sweep.json").read_text())
    assert state["runs"]["slow_walk-s0"]["attempts"] == 1 and state["runs"]["broken-s0"]["attempts"] == 2
    assert (out / "logs" / "slow_walk-s0.log").read_text().count("== attempt") == 1
    assert second < first / 3


SLURM_SWEEP = textwrap.dedent("""
    # the sweep through submitit's local cluster, in a process of its own (submitit and pytest's
    # output capture do not mix)
    import json, sys
    from mjxmimic.ops import sweep
    from mjxmimic.ops.sweep.executors import SlurmExecutor
    spec_path, fake = sys.argv[1:3]
    spec = sweep.load_spec(spec_path)
    executor = SlurmExecutor(spec.out, cluster="local", time_limit_min=5)
    results = sweep.Runner(spec, gpus=[], train_command=[sys.executable, fake], echo=lambda s: None,
                           executor=executor).run()
    sweep.write_report(spec, echo=lambda s: None)
    print(json.dumps(results))
""")


def report_rows(out: Path) -> list[dict]:
    """OUT/report.csv's rows without the timing columns (they differ between executors)."""
    return [{k: v for k, v in r.items() if k not in ("wall_s", "samples_per_s")}
            for r in csv.DictReader((out / "report.csv").open())]


def sweep_both_ways(tmp_path: Path, monkeypatch, name: str, through) -> dict[str, list[dict]]:
    """A 2-run spec (squat finishes, a clip named fail fails) through the local runner and through
    `through(spec, spec_path, fake_train)` (another executor; returns the results); the report
    rows of both, by "local" and `name`."""
    fake = tmp_path / "fake_train.py"
    fake.write_text(FAKE_TRAIN)
    (tmp_path / "fail.txt").write_text("{}")
    monkeypatch.setenv("FAKE_LOG", str(tmp_path / "calls.jsonl"))
    monkeypatch.setenv("FAKE_SLEEP", "0.5")
    rows = {}
    for which in ("local", name):
        spec_path = write_spec(tmp_path / f"{which}.json", preset="cpu", clips=["squat", str(tmp_path / "fail.txt")],
                               set={"run.total_samples": 256}, out=str(tmp_path / which))
        spec = sweep.load_spec(spec_path)
        if which == "local":
            results = sweep.Runner(spec, gpus=[], train_command=[sys.executable, str(fake)], echo=lambda s: None).run()
            sweep.write_report(spec, echo=lambda s: None)
        else:
            results = through(spec, spec_path, fake)
            assert "boom: made to fail" in (spec.out / "logs" / "fail-s0.log").read_text()
        assert sorted(results.values()) == ["failed", "finished"], results
        rows[which] = report_rows(spec.out)
    return rows


def test_slurm_executor_through_submitits_local_cluster(tmp_path, monkeypatch):
    """The same spec through the slurm executor (submitit's local stand-in): one run finishes, the
    failing one is isolated, and the report rows match the local runner's."""
    pytest.importorskip("submitit")

    def slurm(spec, spec_path, fake):
        proc = subprocess.run([sys.executable, "-c", SLURM_SWEEP, str(spec_path), str(fake)], check=False, cwd=REPO,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        assert list((spec.out / "slurm").glob("*_submitted.pkl"))  # went through submitit
        return json.loads(proc.stdout.strip().splitlines()[-1])

    rows = sweep_both_ways(tmp_path, monkeypatch, "slurm", slurm)
    assert rows["slurm"] == rows["local"]


def test_slurm_options_need_a_slurm_cluster(tmp_path):
    pytest.importorskip("submitit")
    from mjxmimic.ops.sweep.executors import SlurmExecutor

    with pytest.raises(UserError, match="no Slurm cluster"):
        SlurmExecutor(tmp_path / "x", cluster="local", partition="gpu")


def test_runs_share_a_gpu_with_their_share_of_its_memory(tmp_path, monkeypatch):
    from mjxmimic.ops.sweep.executors import LocalExecutor

    fake = tmp_path / "fake_train.py"
    fake.write_text(FAKE_TRAIN)
    monkeypatch.setenv("FAKE_LOG", str(tmp_path / "calls.jsonl"))
    monkeypatch.setenv("FAKE_SLEEP", "1.5")
    monkeypatch.delenv("XLA_PYTHON_CLIENT_MEM_FRACTION", raising=False)
    spec = sweep.load_spec(write_spec(tmp_path / "s.json", preset="cpu", clips=["squat"], seeds=[0, 1],
                                      set={"run.total_samples": 256}, out=str(tmp_path / "out")))
    t0 = time.time()
    results = sweep.Runner(spec, gpus=["0"], train_command=[sys.executable, str(fake)], echo=lambda s: None,
                           executor=LocalExecutor(runs_per_gpu=2), max_seconds=600).run()
    assert set(results.values()) == {"finished"}
    calls = [json.loads(line) for line in (tmp_path / "calls.jsonl").read_text().splitlines()]
    assert {(c["gpu"], c["mem"], c["stop_with_parent"]) for c in calls} == {("0", "0.40", "1")}
    # one deadline for the whole sweep, however late a run starts
    assert len({c["deadline"] for c in calls}) == 1 and abs(float(calls[0]["deadline"]) - t0 - 600) < 5
    starts = sorted(c["t"] for c in calls)
    assert starts[1] - starts[0] < 1.4  # both at once on the one GPU
    with pytest.raises(UserError, match="--runs-per-gpu 0"):
        LocalExecutor(0)
