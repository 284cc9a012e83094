"""Weights & Biases tracking (mjxmimic.runs.wandb_log) in W&B's offline mode: no network, no account."""

import io
import json
import sys

import pytest
from standin_env import StandInEnv

from mjxmimic import cli
from mjxmimic.core import config as config_lib
from mjxmimic.runs.train_loop import train

wandb = pytest.importorskip("wandb", reason="the wandb extra is not installed")


@pytest.fixture(autouse=True)
def offline(monkeypatch):
    monkeypatch.setenv("WANDB_MODE", "offline")
    monkeypatch.setenv("WANDB_SILENT", "true")


def _config(total_samples: int):
    return config_lib.make_config("cpu", {"run.total_samples": total_samples, "run.eval_every": 2560,
                                          "run.checkpoint_every": 2560, "run.wandb_project": "mjxmimic-test",
                                          "run.wandb_videos": "false"})


def _offline_runs(run_dir):
    return sorted((run_dir / "wandb").glob("offline-run-*"))


@pytest.fixture
def spy(monkeypatch):
    """What reaches W&B: wandb.init's arguments and every Run.log call, passed on to W&B itself."""
    calls = {"init": [], "log": []}
    real_init, real_log = wandb.init, wandb.Run.log

    def init(**kwargs):
        calls["init"].append(kwargs)
        return real_init(**kwargs)

    def log(self, data, step=None, **kwargs):
        calls["log"].append((step, dict(data)))
        return real_log(self, data, step=step, **kwargs)

    monkeypatch.setattr(wandb, "init", init)
    monkeypatch.setattr(wandb.Run, "log", log)
    return calls


def test_a_run_and_its_resume_log_to_one_wandb_run(tmp_path, spy):
    run_dir = tmp_path / "run"
    train(_config(2560), run_dir, env=StandInEnv(), progress=False)
    run_id = json.loads((run_dir / "wandb.json").read_text())["id"]
    [first] = _offline_runs(run_dir)
    assert first.name.endswith(run_id) and list(first.glob("*.wandb"))  # W&B wrote its offline run
    init = spy["init"][0]
    assert init["project"] == "mjxmimic-test" and init["id"] == run_id and init["resume"] == "allow"
    assert init["config"]["ppo"]["num_envs"] == 32
    final = json.loads((run_dir / "eval.json").read_text())
    evals = [(step, data) for step, data in spy["log"] if "eval/nr" in data]
    assert evals[-1][0] == 2560 and evals[-1][1]["eval/nr"] == pytest.approx(final["nr"])
    steps = [step for step, _ in spy["log"]]
    assert steps == sorted(steps) and any("reward" in data for _, data in spy["log"])

    train(_config(5120), run_dir, resume=True, env=StandInEnv(), progress=False)
    runs = _offline_runs(run_dir)
    assert len(runs) == 2 and all(r.name.endswith(run_id) for r in runs)  # the same W&B run, resumed
    assert spy["init"][1]["id"] == run_id and spy["log"][-1][0] == 5120


def test_best_video(tmp_path, character, spy):
    pytest.importorskip("imageio_ffmpeg", reason="the render extra is not installed")
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable.render import setup_gl
    from mjxmimic.runs.wandb_log import WandbRun

    try:
        setup_gl()
    except UserError as err:
        pytest.skip(f"no headless OpenGL: {err}")
    from test_skills import _random_policy

    from mjxmimic.motion.clip import load_clip_source

    config = config_lib.make_config("cpu", {"run.wandb_project": "mjxmimic-test"})
    pf = _random_policy(character, [load_clip_source("slow_walk", character)], "phase,root_height,bodies")
    tracker = WandbRun(tmp_path, config)
    out = tracker.best_video(1234, lambda: pf)
    tracker.close()
    assert out == tmp_path / "videos" / "best_1234.mp4" and out.stat().st_size > 0
    step, data = spy["log"][-1]
    assert step == 1234 and isinstance(data["eval/video"], wandb.Video)


def test_without_the_package_it_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "wandb", None)
    run_dir = tmp_path / "run"
    assert cli.main(["train", "--preset", "cpu", "--wandb", "proj", "--out", str(run_dir)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.splitlines()[-1].endswith("--wandb needs the 'wandb' package: pip install -e \".[wandb]\"")
    assert not run_dir.exists()


def test_without_a_login_it_is_one_line_before_anything_runs(tmp_path, monkeypatch, capsys):
    """Online mode with no API key (none in the environment or ~/.netrc) and no terminal: one line
    that says how, before the run folder is made (W&B's own traceback came after compilation)."""
    for name in ("WANDB_MODE", "WANDB_API_KEY"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("NETRC", str(tmp_path / "none"))
    monkeypatch.setattr(sys, "stdin", io.StringIO())  # no terminal to ask for a key on
    wandb.teardown()  # the offline settings of the tests before stay in W&B's process-wide singleton
    run_dir = tmp_path / "run"
    assert cli.main(["train", "--preset", "cpu", "--wandb", "proj", "--out", str(run_dir)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("mjxmimic train: error: W&B: ") and "WANDB_MODE=offline" in err
    assert not run_dir.exists()
