"""Compilations in background threads: the train step, the reset and the evaluator compile side by
side, and a command waits for those still running before it exits."""

from __future__ import annotations

import threading
from concurrent.futures import Future
from typing import Any, Callable

_RUNNING: list[Future] = []  # what in_background started


def in_background(fn: Callable, *args: Any) -> Future:
    """fn(*args) in a daemon thread (XLA compiles without the GIL), so that Ctrl-C during a
    compilation stops the command at once."""
    future: Future = Future()
    _RUNNING.append(future)

    def work() -> None:
        try:
            future.set_result(fn(*args))
        except BaseException as err:  # handed to whoever waits for the result
            future.set_exception(err)

    threading.Thread(target=work, name="mjxmimic-compile", daemon=True).start()
    return future


def wait_for_all() -> None:
    """Let the compilations still running finish: a daemon thread that the interpreter's exit cuts
    off inside XLA aborts the process (exit 134 after a clean stop or a one-line error)."""
    while _RUNNING:
        _RUNNING.pop().exception()
