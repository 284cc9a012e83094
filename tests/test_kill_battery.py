"""The fault battery: a run killed with SIGKILL at random moments (mid-iteration, mid-evaluation,
mid-checkpoint) 20 times, resumed after each, still finishes with a whole record."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mjxmimic.runs import checkpoint
from mjxmimic.runs.metrics_log import read

TESTS = Path(__file__).resolve().parent
TOTAL = 409600
DRIVER = f"""
import sys
from pathlib import Path
sys.path.insert(0, {str(TESTS)!r})
from mjxmimic.core import compile_cache, config as config_lib
from mjxmimic.runs.train_loop import train
from standin_env import StandInEnv

compile_cache.enable()  # as `mjxmimic train` does: a resumed run loads its programs from the cache
run_dir = Path(sys.argv[1])
config = config_lib.make_config("cpu", {{"run.total_samples": {TOTAL}, "run.eval_every": 20480,
                                        "run.checkpoint_every": 2048, "run.eval_at_start": "false"}})
resume = (run_dir / "config.json").is_file()  # what a user would do: --resume a started run
train(config, run_dir, resume=resume, env=StandInEnv(), progress=False)
print("finished", flush=True)
"""


@pytest.mark.slow
def test_twenty_kills_and_the_run_still_finishes_whole(tmp_path):
    run_dir = tmp_path / "run"
    rng = np.random.default_rng(7)
    env = dict(os.environ, JAX_PLATFORMS="cpu")

    def start() -> subprocess.Popen:
        return subprocess.Popen([sys.executable, "-c", DRIVER, str(run_dir)], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=env, start_new_session=True)

    def logged() -> int:
        path = run_dir / "metrics.jsonl"
        return path.read_text().count("\n") if path.is_file() else 0

    kills = 0
    while kills < 20:
        proc = start()
        # Kill points count logged iterations, not seconds, so a faster machine still gets its 20
        # kills before the run ends: a few during start-up, the rest after 1 to 30 more lines of
        # the log and a short random delay (mid-iteration, mid-evaluation or mid-checkpoint).
        lines = rng.integers(0, 31)
        target = logged() + lines
        deadline = time.time() + (float(rng.uniform(0.5, 3.0)) if lines == 0 else 300.0)
        while proc.poll() is None and time.time() < deadline and (lines == 0 or logged() < target):
            time.sleep(0.01)
        time.sleep(float(rng.uniform(0.0, 0.3)))
        if proc.poll() is not None:
            out, err = proc.communicate()
            assert proc.returncode == 0, err[-2000:]
            break  # it finished before this kill
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        kills += 1
    if not (run_dir / "eval.json").is_file():
        proc = start()
        out, err = proc.communicate(timeout=600)
        assert proc.returncode == 0 and "finished" in out, err[-2000:]

    assert kills >= 10  # most attempts were killed, not finished
    final = json.loads((run_dir / "eval.json").read_text())
    assert final["samples"] == TOTAL
    steps = [r["step"] for r in read(run_dir) if "samples_per_s" in r]
    assert steps == list(range(512, TOTAL + 1, 512))  # every iteration once, in order
    assert checkpoint.latest_checkpoint(run_dir) == TOTAL
