"""Run metrics: one JSON object per line in RUN/metrics.jsonl, mirrored to TensorBoard (RUN/tb/)
and, where asked, to another tracker (Weights & Biases: mjxmimic.runs.wandb_log).

Each line has "step" (environment samples so far) and "wall" (seconds since the run began,
summed over resumed calls), plus slash-named scalars. Appends, so a resumed run continues the
same file (and TensorBoard adds an event file under tb/ with steps that continue).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from mjxmimic.runs.folder import metrics_path, tensorboard_dir


def _plain(value: Any) -> Any:
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else (1e308 if value > 0 else -1e308)
    return value


class MetricsLog:
    def __init__(self, run_dir: Path, tensorboard: bool = True, mirror: Any = None):
        """`mirror` has log(step, record) and close()."""
        self.path = metrics_path(run_dir)
        self._mirror = mirror
        self._file = self.path.open("a")
        self._tb = None
        if tensorboard:
            from tensorboardX import SummaryWriter

            self._tb = SummaryWriter(str(tensorboard_dir(run_dir)))

    def write(self, step: int, wall: float, values: dict[str, Any]) -> dict:
        record = {"step": int(step), "wall": round(float(wall), 3)}
        record.update({k: _plain(v) for k, v in values.items()})
        self._file.write(json.dumps(record) + "\n")
        self._file.flush()
        if self._tb is not None:
            for k, v in record.items():
                if k != "step" and isinstance(v, (int, float)) and not isinstance(v, bool):
                    self._tb.add_scalar(k, v, global_step=int(step))
        if self._mirror is not None:
            self._mirror.log(step, record)
        return record

    def close(self) -> None:
        self._file.close()
        if self._tb is not None:
            self._tb.close()
        if self._mirror is not None:
            self._mirror.close()

    def __enter__(self) -> "MetricsLog":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read(run_dir: Path) -> list[dict]:
    """Every record of RUN/metrics.jsonl ([] when there is none); a line cut short by a crash is skipped."""
    try:
        text = metrics_path(run_dir).read_text()
    except OSError:
        return []
    rows = []
    for line in text.splitlines():
        try:
            rows.append(json.loads(line))
        except ValueError:
            continue
    return rows


def truncate(run_dir: Path, step: int) -> int:
    """Drop the records past `step` (and any line cut short by a crash) from RUN/metrics.jsonl, so
    that a run resumed from the checkpoint at `step` never repeats steps; the file is replaced
    whole. Returns the number of records dropped."""
    path = metrics_path(run_dir)
    if not path.is_file():
        return 0
    lines = path.read_text().splitlines()
    keep = []
    for line in lines:
        try:
            if json.loads(line)["step"] <= step:
                keep.append(line)
        except (ValueError, KeyError, TypeError):
            continue
    if len(keep) != len(lines):
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text("".join(f"{line}\n" for line in keep))
        tmp.replace(path)
    return len(lines) - len(keep)
