"""`--seed` on every command, in one range (config.SEED_MAX says why), refused in one line outside it."""

from __future__ import annotations

import argparse

from mjxmimic.core.config import SEED_MAX


def seed(text: str) -> int:
    """argparse type of --seed."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"{value}: must be in 0..{SEED_MAX}")
    return value
