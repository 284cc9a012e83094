"""A sweep's state on disk: OUT/sweep.json (per run its status, attempts, exit code, seconds,
log tail) and whether a run folder holds a finished run; read by the runner and the report."""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path
from typing import Any

from mjxmimic.core import config as config_lib
from mjxmimic.runs import folder
from mjxmimic.ops.sweep.spec import Spec

STATE_FILE = "sweep.json"


def read_json(path: Path) -> dict | None:
    """A JSON object from `path`, or None when it is missing, unreadable or not an object."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def is_finished(run_dir: Path, cfg: config_lib.Config) -> bool:
    """eval.json is there and the run reached its run.total_samples (or stopped at the target NR)."""
    final = read_json(folder.eval_path(run_dir))
    if final is None:
        return False
    if final.get("reason") == "target":
        return True
    return int(final.get("samples", -1)) >= cfg.run.total_samples


class State:
    """OUT/sweep.json: {"name", "spec", "spec_content", "updated", "runs": {name: record}}."""

    def __init__(self, spec: Spec):
        self.path = spec.out / STATE_FILE
        self.lock = threading.Lock()
        data = read_json(self.path) or {}
        self.data = {"name": spec.name, "spec": str(spec.path), "spec_content": spec.raw,
                     "runs": data.get("runs", {}) if isinstance(data.get("runs"), dict) else {}}

    def record(self, name: str) -> dict:
        return self.data["runs"].get(name, {})

    def update(self, name: str, **values: Any) -> None:
        with self.lock:
            self.data["runs"].setdefault(name, {}).update(values)
            self._write()

    def _write(self) -> None:
        self.data["updated"] = now()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(self.data, indent=2) + "\n")
        os.replace(tmp, self.path)

    def save(self) -> None:
        with self.lock:
            self._write()


def now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S")


# ---- the report -------------------------------------------------------------------------------
