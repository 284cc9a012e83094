"""`--character` on the commands that read the character from a run folder, a policy or a
composite file (eval, play, render, export): there the file decides, so the option is a check."""

from __future__ import annotations

import argparse
from pathlib import Path

from mjxmimic.core.errors import UserError


def add_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--character", metavar="NAME|PATH", default=None,
                        help="the character the policy must move: humanoid, dog3d, g1 or an MJCF file (the run or "
                             "policy file holds it; given, a different one is refused)")


def check(given: str | None, source: Path) -> None:
    """The character `given` must be the file's (by MJCF file name), so that a user who expects
    another one learns it from one line instead of from a playback of the wrong body."""
    if given is None:
        return
    from mjxmimic.core.character import resolve_xml
    from mjxmimic.portable import composite, policy_file
    from mjxmimic.runs.folder import load_config

    want = resolve_xml(given).stem
    source = Path(source)
    if source.is_dir():
        files = [Path(load_config(source).character.xml).stem]
    elif composite.is_composite(source):
        files = [Path(e.manifest["character"]["file"]).stem for e in composite.read(source).experts]
    else:
        files = [Path(policy_file.read(source).manifest["character"]["file"]).stem]
    if any(have != want for have in files):
        raise UserError(f"--character {given}: {source} moves {files[0]}, not {want} (it holds its character; "
                        "drop --character)")
