"""mjxmimic.runs.folder: the run folder's one owner. Its errors are one line naming the folder, and
it (with the policy file format) stays importable without JAX, so sweeps and `play` can use it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.portable.policy_file import read_npz
from mjxmimic.runs import folder

REPO = Path(__file__).resolve().parent.parent


def test_folder_and_policy_file_import_without_jax():
    code = ("import sys, mjxmimic.runs.folder, mjxmimic.portable.policy_file; "
            "sys.exit(3 if any(m == 'jax' or m.startswith('jax.') for m in sys.modules) else 0)")
    assert subprocess.run([sys.executable, "-c", code], cwd=REPO, timeout=120, check=False).returncode == 0


def test_missing_folder_config_and_policy_are_one_line_errors(tmp_path):
    with pytest.raises(UserError, match="run folder not found"):
        folder.load_config(tmp_path / "missing")
    (tmp_path / "policy.npz").write_bytes(b"")
    with pytest.raises(UserError, match="policy.npz: a file, not a run folder"):
        folder.require(tmp_path / "policy.npz")
    (tmp_path / "policy.npz").unlink()
    with pytest.raises(UserError, match=r"not a run folder \(no config.json\)"):
        folder.load_config(tmp_path)
    with pytest.raises(UserError, match="without policy.npz"):
        folder.load_policy_file(tmp_path)
    with pytest.raises(UserError, match="neither a policy file nor a run folder with checkpoints"):
        folder.load_policy_file(tmp_path, export_if_missing=True)
    with pytest.raises(UserError, match="policy file not found"):
        folder.load_policy_file(tmp_path / "policy.npz")


def test_a_policy_file_that_is_no_npz_archive_is_named_so(tmp_path):
    """A text file, a .npy and an npz cut short: one line saying the file is not a whole npz
    archive, never numpy's hint to load the file as a pickle."""
    np.savez(tmp_path / "whole.npz", a=np.zeros(3))
    np.save(tmp_path / "array.npy", np.zeros(3))
    files = {"text.npz": b"garbage\n", "array.npz": (tmp_path / "array.npy").read_bytes(),
             "cut.npz": (tmp_path / "whole.npz").read_bytes()[:-30]}
    for name, content in files.items():
        (tmp_path / name).write_bytes(content)
        with pytest.raises(UserError, match=f"{name}: cannot read as an npz policy file \\(not a whole npz archive") as err:
            read_npz(tmp_path / name)
        assert "pickle" not in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(UserError, match="whole.npz: not an mjxmimic policy file"):
        read_npz(tmp_path / "whole.npz")


def test_config_and_eval_round_trip(tmp_path):
    run_dir = tmp_path / "run"
    config = config_lib.make_config("cpu")
    assert not folder.holds_run(run_dir)
    folder.write_config(run_dir, config)
    assert folder.holds_run(run_dir) and folder.load_config(run_dir) == config
    assert folder.read_eval(run_dir) is None
    folder.write_eval(run_dir, {"nr": 0.5})
    assert folder.read_eval(run_dir) == {"nr": 0.5}
    assert sorted(p.name for p in run_dir.iterdir()) == sorted([folder.CONFIG, folder.EVAL])  # no .tmp left
    folder.eval_path(run_dir).write_text("{not json")
    with pytest.raises(UserError, match="eval.json: not valid JSON"):
        folder.read_eval(run_dir)
    folder.eval_path(run_dir).write_text("[1]")
    with pytest.raises(UserError, match="eval.json: expected a JSON object, got list"):
        folder.read_eval(run_dir)
    folder.config_path(run_dir).write_text("[1, 2]")
    with pytest.raises(UserError, match="config.json: expected a JSON object of config sections, got list"):
        folder.load_config(run_dir)


def test_has_checkpoint_needs_a_complete_one(tmp_path):
    assert not folder.has_checkpoint(tmp_path)
    step = folder.checkpoint_dir(tmp_path) / "512"
    step.mkdir(parents=True)
    assert not folder.has_checkpoint(tmp_path)  # orbax has not committed it
    (step / "_CHECKPOINT_METADATA").write_text(json.dumps({}))
    assert folder.has_checkpoint(tmp_path)


def test_a_run_folder_exported_in_memory_keeps_the_warp_notice_off_the_terminal(tmp_path):
    """compose and render export a run folder without policy.npz in memory: that path imports MJX
    too, so it must do so as train and eval do (mjxmimic.core.jax_setup)."""
    run_dir = tmp_path / "run"
    folder.write_config(run_dir, config_lib.make_config("cpu"))
    (run_dir / "checkpoints" / "80").mkdir(parents=True)
    (run_dir / "checkpoints" / "80" / "_CHECKPOINT_METADATA").write_text("{}")  # complete, but unreadable
    code = ("import sys; sys.modules['warp'] = None; from mjxmimic.cli import main; "
            "sys.exit(main(sys.argv[1:]))")
    result = subprocess.run([sys.executable, "-c", code, "compose", str(run_dir), "--out", str(tmp_path / "c.npz")],
                            cwd=REPO, capture_output=True, text=True, timeout=300)
    assert result.returncode == 2, result.stderr
    assert "Failed to import" not in result.stdout + result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
