"""The training loop's progress on stderr, kept apart from the loop: a rich bar in a terminal, a
plain line now and then in a log."""

from __future__ import annotations

import sys
import time


class Progress:
    """Progress to stderr: a rich bar (samples, samples/s, mean reward per step) when `mode` is
    True, a plain line every 30 s when it is "plain" (logs of non-interactive runs), else nothing."""

    def __init__(self, mode: bool | str, total: int, completed: int):
        self.mode = mode
        self.total, self.completed = total, completed
        self._progress = None
        self._last_line = time.time()

    def __enter__(self):
        if self.mode is True:
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self._progress = Progress(
                TextColumn("[bold]train"), BarColumn(),
                TextColumn("{task.completed:,.0f}/{task.total:,.0f} samples"),
                TextColumn("{task.fields[sps]:,.0f} samples/s"),
                TextColumn("reward {task.fields[reward]:.3f}"),
                TimeElapsedColumn(), console=Console(stderr=True))
            self._progress.__enter__()
            self._task = self._progress.add_task("train", total=self.total, completed=self.completed,
                                                 sps=0.0, reward=float("nan"))
        return self

    def update(self, completed: int, sps: float, reward: float) -> None:
        if self._progress is not None:
            self._progress.update(self._task, completed=completed, sps=sps, reward=reward)
        elif self.mode == "plain" and time.time() - self._last_line >= 30.0:
            self._last_line = time.time()
            print(f"train: {completed:,}/{self.total:,} samples, {sps:,.0f} samples/s, reward {reward:.3f}",
                  file=sys.stderr, flush=True)

    def note(self, text: str) -> None:
        if self._progress is not None:
            self._progress.console.print(text)
        elif self.mode == "plain":
            print(f"train: {text}", file=sys.stderr, flush=True)

    def __exit__(self, *exc):
        if self._progress is not None:
            self._progress.__exit__(*exc)
