"""Motion datasets: several clips for one controller (DEEPMIMIC.md, "Beyond one clip"), with the
weights by which RSI draws them.

A dataset is a JSON or YAML file, `--clip FILE` wherever a clip is accepted:

    {"clips": [{"clip": "walk", "weight": 2}, {"clip": "walker/turn_left0.txt"}, "run"]}

Each entry is a clip NAME or PATH (a path is tried relative to the dataset file first), alone or
with a positive weight (default 1). A file is read as a dataset when its top level holds "clips";
a clip file holds "Frames". Other top-level keys (such as "about") are free for notes. The
package's own datasets (mjxmimic/motion/datasets/, e.g. `walker`) resolve by name.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, NamedTuple

from mjxmimic.core.character import Character
from mjxmimic.core.errors import UserError
from mjxmimic.motion.clip import Clip, load_clip, resolve_clip

SUFFIXES = (".json", ".yaml", ".yml")


class Dataset(NamedTuple):
    path: Path
    clips: list[Clip]
    weights: list[float]


def _read(path: Path) -> Any:
    text = path.read_text()
    if path.suffix.lower() in (".yaml", ".yml"):
        try:
            import yaml
        except ImportError:
            raise UserError(f"{path}: reading a YAML dataset needs PyYAML (pip install pyyaml), or write it as JSON") from None
        try:
            return yaml.safe_load(text)
        except yaml.YAMLError as err:
            raise UserError(f"{path}: not valid YAML ({str(err).splitlines()[0]})") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise UserError(f"{path}: not valid JSON ({err.msg} at line {err.lineno})") from None


DATASETS_DIR = Path(__file__).resolve().parent / "datasets"


def _path(source: str | Path) -> Path:
    """A dataset file as given, else one of the package's datasets by name."""
    path = Path(str(source)).expanduser()
    if path.is_file() or not str(source) or "/" in str(source):
        return path
    own = DATASETS_DIR / f"{source}.json"
    return own if own.is_file() else path


def is_dataset(source: str | Path) -> bool:
    """`source` names an existing .json/.yaml file whose top level holds "clips" (or one of the
    package's datasets)."""
    path = _path(source)
    if path.suffix.lower() not in SUFFIXES or not path.is_file():
        return False
    try:
        data = _read(path)
    except UserError:
        return path.suffix.lower() != ".json"  # a broken YAML file can only be a dataset
    return isinstance(data, dict) and "clips" in data


def load_dataset(source: str | Path, character: Character, user_dir: str | Path | None = None) -> Dataset:
    """The dataset's clips (loaded and checked like any clip) and their weights; one-line errors
    name the file and the entry."""
    path = _path(source)
    data = _read(path)
    entries = data.get("clips") if isinstance(data, dict) else None
    if not isinstance(entries, list) or not entries:
        raise UserError(f"{path}: a dataset needs a non-empty list under \"clips\"")
    clips, weights = [], []
    for i, entry in enumerate(entries):
        where = f"{path}: clips[{i}]"
        if isinstance(entry, str):
            entry = {"clip": entry}
        if not isinstance(entry, dict) or not isinstance(entry.get("clip"), str) or not entry["clip"]:
            raise UserError(f"{where}: expected a clip name or {{\"clip\": NAME, \"weight\": W}}")
        unknown = sorted(set(entry) - {"clip", "weight"})
        if unknown:
            raise UserError(f"{where}: unknown key {unknown[0]!r} (keys: clip, weight)")
        weight = entry.get("weight", 1.0)
        if isinstance(weight, bool) or not isinstance(weight, (int, float)) or not weight > 0:
            raise UserError(f"{where}: weight {weight!r} must be a positive number")
        local = path.parent / entry["clip"]
        try:
            clip = load_clip(local if local.is_file() else resolve_clip(entry["clip"], user_dir, character.clip_prefix),
                             character)
        except UserError as err:
            raise UserError(f"{where}: {err}") from None
        clips.append(clip)
        weights.append(float(weight))
    names = [c.name for c in clips]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise UserError(f"{path}: clip {twice[0]!r} is listed twice (give it a larger weight instead)")
    return Dataset(path=path, clips=clips, weights=weights)
