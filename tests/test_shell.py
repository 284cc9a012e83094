"""Faults a training run must survive: a second writer, SIGTERM, kill -9 and resume, a corrupt
newest checkpoint, a policy that turns NaN; each answered with one line, nothing lost."""

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from mjxmimic import cli
from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.runs import checkpoint, folder
from mjxmimic.runs.metrics_log import read
from mjxmimic.runs.train_loop import train
from standin_env import StandInEnv

REPO = Path(__file__).resolve().parent.parent


def _config(**run):
    overrides = {"run.total_samples": 5120, "run.eval_every": 2560, "run.checkpoint_every": 2560}
    overrides.update({f"run.{k}": v for k, v in run.items()})
    return config_lib.make_config("cpu", overrides)


def _steps(run_dir):
    return [r["step"] for r in read(run_dir) if "samples_per_s" in r]


def test_a_second_writer_is_refused_and_a_dead_ones_lock_is_not_in_the_way(tmp_path):
    run_dir = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import time
        from mjxmimic.runs import folder
        with folder.writer_lock({str(run_dir)!r}):
            print("locked", flush=True)
            time.sleep(60)
    """)], cwd=REPO, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(UserError, match=r"process \d+ is training this run"):
            train(_config(), run_dir, env=StandInEnv(), progress=False)
        assert not (run_dir / "config.json").exists()  # nothing written
    finally:
        holder.kill()  # kill -9: the OS releases the lock
        holder.wait()
    out = train(_config(), run_dir, env=StandInEnv(), progress=False)
    assert out.reason == "done"
    with pytest.raises(UserError, match="already holds a run"):
        train(_config(), run_dir, env=StandInEnv(), progress=False)


def test_out_naming_a_file_is_one_line(tmp_path, capsys):
    target = tmp_path / "file.txt"
    target.write_text("keep me")
    assert cli.main(["train", "--preset", "cpu", "--out", str(target)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"mjxmimic train: error: {target}: exists and is not a folder"]  # before any env is built
    assert target.read_text() == "keep me"


@pytest.mark.parametrize("key, value, why", [
    ("env.events", "nope", "'nope' is not an event"),
    ("env.observations", "phase,nope", "'phase,nope' must name terms among"),
    ("reward.weights", "nope=1", "no term 'nope' in the released reward"),
])
def test_a_bad_term_name_is_one_line_before_the_env_is_built(key, value, why, tmp_path, capsys):
    """Term names are read with the config, so a run (or each run of a sweep) is refused before
    anything is built or written."""
    out = tmp_path / "run"
    assert cli.main(["train", "--preset", "cpu", "--set", f"{key}={value}", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"mjxmimic train: error: config key '{key}': {why}")
    assert not out.exists()


def test_resume_after_a_crash_drops_the_rows_past_the_checkpoint(tmp_path):
    run_dir = tmp_path / "run"
    train(_config(total_samples=2560), run_dir, env=StandInEnv(), progress=False)
    # what a kill -9 leaves: rows of iterations after the last checkpoint and a line cut short
    with (run_dir / "metrics.jsonl").open("a") as f:
        f.write('{"step": 3072, "wall": 9.0, "samples_per_s": 1.0, "reward": 0.5}\n{"step": 3584, "wa')
    train(_config(), run_dir, resume=True, env=StandInEnv(), progress=False)
    steps = _steps(run_dir)
    assert steps == [512 * i for i in range(1, 11)]  # no repeats, never backwards
    assert all(isinstance(r, dict) for r in read(run_dir))


def test_resume_of_a_run_killed_before_its_first_checkpoint_starts_it_over(tmp_path):
    run_dir = tmp_path / "run"
    config = _config()
    folder.write_config(run_dir, config)  # what a kill -9 during the first iterations leaves
    (run_dir / "metrics.jsonl").write_text('{"step": 512, "wall": 1.0, "samples_per_s": 1.0}\n{"step": 1024, "wa')
    out = train(config, run_dir, resume=True, env=StandInEnv(), progress=False)
    assert out.reason == "done" and _steps(run_dir) == [512 * i for i in range(1, 11)]


def test_a_corrupt_newest_checkpoint_falls_back_to_the_one_before(tmp_path, capfd):
    run_dir = tmp_path / "run"
    train(_config(), run_dir, env=StandInEnv(), progress=False)
    assert checkpoint.kept_checkpoints(run_dir) == [2560, 5120]
    config_before = (run_dir / "config.json").read_text()
    for data in (run_dir / "checkpoints" / "5120").rglob("*"):
        if data.is_file() and data.parent.name == "d":
            data.write_bytes(data.read_bytes()[:8])  # cut short
    out = train(_config(total_samples=7680), run_dir, resume=True, env=StandInEnv(), progress=False)
    assert "checkpoint 5120 cannot be read" in capfd.readouterr().err
    assert out.reason == "done" and out.env_steps == 7680
    assert _steps(run_dir) == [512 * i for i in range(1, 16)]  # 5 to 10 again, from checkpoint 2560
    assert (run_dir / "config.json").read_text() != config_before  # rewritten (total_samples) after the restore


def test_a_policy_that_turns_nan_stops_with_one_line_and_keeps_the_good_checkpoint(tmp_path):
    run_dir = tmp_path / "run"
    train(_config(total_samples=2560), run_dir, env=StandInEnv(), progress=False)
    wreck = config_lib.apply_overrides(_config(total_samples=20480), {"ppo.learning_rate": 1e9})
    with pytest.raises(UserError, match=r"training stopped: .* is nan at .*last good checkpoint, at 2,560"):
        train(wreck, run_dir, resume=True, env=StandInEnv(), progress=False)
    assert checkpoint.latest_checkpoint(run_dir) == 2560
    env = StandInEnv()
    params, _ = folder.load_policy_params(run_dir, env.observation_size, env.action_size)
    assert all(np.isfinite(v).all() for layer in params["policy"].values() for v in layer.values())


@pytest.mark.parametrize("command", [["train", "--preset", "cpu"], ["eval", "RUN"], ["play", "POLICY.npz"]])
@pytest.mark.parametrize("seed", ["-1", str(config_lib.SEED_MAX + 1)])
def test_a_seed_outside_32_bits_is_one_line(command, seed, capsys):
    # numpy's generators refuse negative seeds (a traceback in play) and JAX's keys keep 32 bits
    with pytest.raises(SystemExit) as exit_:
        cli.main([*command, "--seed", seed])
    assert exit_.value.code == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].endswith(f"argument --seed: {seed}: must be in 0..4294967295")
    for key in ("run.seed", "terrain.seed"):
        with pytest.raises(UserError, match=f"'{key}': must be in 0..4294967295"):
            config_lib.make_config("cpu", {key: seed})


def test_no_hidden_layer_is_refused():
    with pytest.raises(UserError, match="ppo.policy_hidden': needs at least one layer"):
        config_lib.make_config("cpu", {"ppo.policy_hidden": ""})
    with pytest.raises(UserError, match="'ppo.policy_hidden': '64,,64' is not a valid tuple"):
        config_lib.make_config("cpu", {"ppo.policy_hidden": "64,,64"})  # a size left out, not a layer less


@pytest.mark.parametrize("key, value, message", [
    ("ppo.entropy_cost", "nan", "must be a finite number"),  # nan passes every bound
    ("ppo.learning_rate", "inf", "must be a finite number"),  # trained until the loss turned nan
    ("env.mass_range", "1,nan", "must be a finite number"),
    ("run.target_nr", "1.5", "must be in \\[0, 1\\]"),  # never reached: a run that cannot stop early
    ("ppo.clipping_epsilon", "0", "must be positive"),  # a policy that cannot move
])
def test_numbers_that_no_setting_means_are_refused(key, value, message):
    with pytest.raises(UserError, match=f"'{key}': {message}"):
        config_lib.make_config("cpu", {key: value})


@pytest.mark.parametrize("command", [["train", "--out", ""], ["sweep", ""], ["export", "RUN", "--out", " "]])
def test_an_empty_path_is_refused_not_read_as_the_current_folder(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        cli.main(command)
    assert exit_.value.code == 2 and capsys.readouterr().err.strip().endswith("empty path")
    assert not list(tmp_path.iterdir())  # `train --out ""` trained into the current folder


def test_a_term_named_twice_is_refused():
    from mjxmimic.task import observation, reward

    with pytest.raises(UserError, match="'env.observations': 'phase' is listed twice"):
        observation.parse("phase,root_height,bodies,phase")
    with pytest.raises(UserError, match="'reward.weights': 'pose' is given twice"):  # the last one won
        reward.parse_weights("pose=0.6,root=0,pose=0.1")


def test_a_full_disk_stops_with_one_line_and_keeps_the_last_checkpoint(tmp_path, monkeypatch):
    import errno

    run_dir = tmp_path / "run"
    save = checkpoint.save

    def save_until_full(run_dir_, ts, **kwargs):
        if int(ts.env_steps) > 2560:
            raise OSError(errno.ENOSPC, "No space left on device")
        return save(run_dir_, ts, **kwargs)

    monkeypatch.setattr(checkpoint, "save", save_until_full)
    with pytest.raises(UserError, match=r"the disk is full .*checkpoint \(at 2,560 samples\) is kept") as err:
        train(_config(), run_dir, env=StandInEnv(), progress=False)
    assert "\n" not in str(err.value)
    monkeypatch.setattr(checkpoint, "save", save)
    assert checkpoint.kept_checkpoints(run_dir) == [2560]
    out = train(_config(), run_dir, resume=True, env=StandInEnv(), progress=False)  # space freed: go on
    assert out.reason == "done" and _steps(run_dir) == [512 * i for i in range(1, 11)]


def test_a_disk_that_fills_at_the_final_evaluation_stops_with_one_line(tmp_path, monkeypatch):
    """The best checkpoint of the evaluation after the last iteration is the last thing written;
    orbax wraps the full disk into a long ValueError."""
    run_dir = tmp_path / "run"
    save = checkpoint.save

    def best_fills_the_disk(run_dir_, ts, **kwargs):
        if kwargs.get("best") and int(ts.env_steps) == 5120:
            raise ValueError("RESOURCE_EXHAUSTED: Error writing ...\nFailed writing: No space left on device")
        return save(run_dir_, ts, **kwargs)

    monkeypatch.setattr(checkpoint, "save", best_fills_the_disk)
    with pytest.raises(UserError, match=r"the disk is full \(RESOURCE_EXHAUSTED.*\(at 5,120 samples\) is kept") as err:
        train(_config(eval_every=4096), run_dir, env=StandInEnv(), progress=False)
    assert "\n" not in str(err.value)
    assert checkpoint.latest_checkpoint(run_dir) == 5120


def test_a_checkpoint_the_disk_cannot_hold_is_refused_before_any_of_it_is_written(tmp_path, monkeypatch):
    import collections
    import shutil

    run_dir = tmp_path / "run"
    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage(1 << 30, (1 << 30) - 4096, 4096))
    with pytest.raises(UserError, match=r"the disk is full \(.*0\.0 MiB free, a checkpoint needs about .*\); "
                                        r"training stopped, no checkpoint was written"):
        train(_config(), run_dir, env=StandInEnv(), progress=False)
    assert not folder.checkpoint_dir(run_dir).exists() and not folder.best_dir(run_dir).exists()
