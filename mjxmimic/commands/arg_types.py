"""argparse types shared by the commands, so that one kind of value is read and refused alike
everywhere, in one line."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from mjxmimic.core.config import SEED_MAX


def seed(text: str) -> int:
    """--seed, in the range of config.SEED_MAX (which says why)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"{value}: must be in 0..{SEED_MAX}")
    return value


def path(text: str) -> Path:
    """A file or folder argument; an empty one (an unset shell variable, say) is refused rather than
    read as the current folder, which `train --out ""` would have filled with a run."""
    if not text.strip():
        raise argparse.ArgumentTypeError("empty path")
    return Path(text)


def at_least(minimum: float, kind: type = int) -> Callable[[str], float]:
    """A count or amount option of at least `minimum` (a finite number of type `kind`), refused
    when parsed, so that `sweep --dry-run` refuses what the sweep itself would."""
    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'}") from None
        if not minimum <= value < float("inf"):
            raise argparse.ArgumentTypeError(f"{text}: must be at least {minimum:g}")
        return value

    return parse
