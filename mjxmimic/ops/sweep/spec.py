"""A sweep spec file: its fields, the expansion into runs, run names and one-line spec errors
(the format is in `mjxmimic.ops.sweep`)."""

from __future__ import annotations

import dataclasses
import fnmatch
import hashlib
import itertools
import json
import math
import re
from pathlib import Path
from typing import Any

from mjxmimic.core import config as config_lib
from mjxmimic.motion.clip import clip_label
from mjxmimic.core.errors import UserError


SPEC_FIELDS = ("name", "description", "preset", "clip", "clips", "grid", "runs", "seeds", "set", "out", "ray")
RAY_FIELDS = ("scheduler", "metric", "grace_period", "max_t", "reduction_factor")
RAY_SCHEDULERS = ("asha",)
RAY_METRICS = ("eval/nr", "eval/fall_rate")
MAX_NAME = 100
_SAFE = re.compile(r"[^A-Za-z0-9._=+-]+")
_LABEL = re.compile(r"[A-Za-z0-9][A-Za-z0-9._=+-]{0,39}")


# ---- the spec ---------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class RunSpec:
    name: str
    clip: str
    seed: int
    overrides: dict[str, Any]  # this run's own grid/runs overrides (spec values)
    args: dict[str, str]  # every --set of the run (set + grid + runs entry) as command-line strings
    config: config_lib.Config  # the resolved config the run will have
    order: tuple[int, ...]  # (clip, grid combination, runs entry, seed): the report's row order


@dataclasses.dataclass(frozen=True)
class Spec:
    path: Path
    name: str
    description: str
    preset: str
    clips: list[str]
    seeds: list[int]
    common: dict[str, Any]
    grid: dict[str, list]
    entries: list[dict[str, Any]]
    out: Path
    runs: list[RunSpec]  # in execution order: seeds outermost, then clips, grid, runs entries
    raw: dict
    ray: dict[str, Any] = dataclasses.field(default_factory=dict)  # the Ray executor's scheduler, checked

    @property
    def varying_keys(self) -> list[str]:
        keys = list(self.grid)
        for entry in self.entries:
            keys += [k for k in entry if k not in keys]
        return keys

    def run_dir(self, run: RunSpec) -> Path:
        return self.out / run.name

    def log_path(self, run: RunSpec) -> Path:
        return self.out / "logs" / f"{run.name}.log"


def cli_value(value: Any) -> str:
    """A spec value as `--set key=VALUE` takes it (what config._coerce parses back)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isfinite(value) and value.is_integer() and abs(value) < 1e15:
            return str(int(value))
        return repr(value)
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)) and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                for v in value):
        return ",".join(cli_value(v) for v in value)
    raise ValueError(f"{json.dumps(value)} is not a config value (a number, string, boolean or list of numbers)")


def _label_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (list, tuple)):
        return "x".join(_label_value(v) for v in value)
    text = str(value)
    return Path(text).stem if "/" in text else text


def _short_hash(obj: Any) -> str:
    return hashlib.sha1(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:8]


class _SpecError(Exception):
    """A problem with the spec; load_spec turns it into a UserError naming the file."""


def _check_key(key: Any, where: str) -> str:
    if not isinstance(key, str) or key.count(".") != 1:
        raise _SpecError(f"{where}: config key {key!r}: expected section.key")
    if key == "clip.name":
        raise _SpecError(f"{where}: config key 'clip.name': give clips with \"clips\"")
    if key == "run.seed":
        raise _SpecError(f"{where}: config key 'run.seed': give seeds with \"seeds\"")
    return key


def _overrides(obj: Any, where: str) -> dict[str, Any]:
    if not isinstance(obj, dict):
        raise _SpecError(f"{where}: expected an object of section.key: value")
    out = {}
    for key, value in obj.items():
        _check_key(key, where)
        try:
            cli_value(value)
        except ValueError as err:
            raise _SpecError(f"{where}: config key {key!r}: {err}") from None
        out[key] = value
    return out


def _runs_entry(obj: Any, where: str) -> tuple[str | None, dict[str, Any]]:
    """A runs entry's "label" (its part of the run names instead of its key=value pairs, for an
    entry of many keys) and its overrides."""
    if not isinstance(obj, dict) or "label" not in obj:
        return None, _overrides(obj, where)
    label = obj["label"]
    if not isinstance(label, str) or not _LABEL.fullmatch(label):
        raise _SpecError(f'{where}: "label": expected a name of letters, digits, ".", "_", "=", "+" or "-"')
    return label, _overrides({k: v for k, v in obj.items() if k != "label"}, where)


def _origin(message: str, common: dict, grid: dict, index: int, entry: dict) -> str:
    """"set: " / "grid: " / "runs[i]: " for the key a config error names, else ""."""
    m = re.search(r"config key '([^']+)'", message)
    if m is None:
        return ""
    key = m.group(1)
    if key in common:
        return "set: "
    if key in grid:
        return "grid: "
    if key in entry:
        return f"runs[{index}]: "
    return ""


def _ray_block(raw: Any, runs: list[RunSpec]) -> dict[str, Any]:
    """The spec's "ray" block (a Tune scheduler for --executor ray) with its defaults filled in;
    time (grace_period, max_t) is counted in samples, the `step` of RUN/metrics.jsonl."""
    if not isinstance(raw, dict):
        raise _SpecError("ray: expected an object (scheduler, metric, grace_period, max_t, reduction_factor)")
    unknown = [k for k in raw if k not in RAY_FIELDS]
    if unknown:
        raise _SpecError(f"ray: unknown field {unknown[0]!r} (fields: {', '.join(RAY_FIELDS)})")
    if not raw:
        return {}
    if raw.get("scheduler") not in RAY_SCHEDULERS:
        raise _SpecError(f"ray: scheduler {raw.get('scheduler')!r}: expected one of {', '.join(RAY_SCHEDULERS)}")
    out = {"scheduler": raw["scheduler"], "metric": raw.get("metric", "eval/nr"),
           "max_t": raw.get("max_t", max(r.config.run.total_samples for r in runs)),
           "reduction_factor": raw.get("reduction_factor", 4)}
    if out["metric"] not in RAY_METRICS:
        raise _SpecError(f"ray: metric {out['metric']!r}: expected one of {', '.join(RAY_METRICS)}")
    if "grace_period" not in raw:
        raise _SpecError("ray: grace_period: required with a scheduler (samples a run trains before it may be stopped)")
    out["grace_period"] = raw["grace_period"]
    for key in ("grace_period", "max_t"):
        if not isinstance(out[key], int) or isinstance(out[key], bool) or out[key] < 1:
            raise _SpecError(f"ray: {key} {json.dumps(out[key])}: expected a positive number of samples")
    if out["grace_period"] > out["max_t"]:
        raise _SpecError(f"ray: grace_period {out['grace_period']} is more than max_t {out['max_t']}")
    rf = out["reduction_factor"]
    if not isinstance(rf, (int, float)) or isinstance(rf, bool) or not rf > 1:
        raise _SpecError(f"ray: reduction_factor {json.dumps(rf)}: expected a number greater than 1")
    return out


def load_spec(path: str | Path, out: str | Path | None = None, check_clips: bool = True) -> Spec:
    """Read, validate and expand a spec; every problem is a UserError naming the file."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: sweep spec not found" if not path.exists() else f"{path}: not a file")
    try:
        raw = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise UserError(f"{path}: not valid JSON ({err.msg} at line {err.lineno})") from None
    except UnicodeDecodeError:
        raise UserError(f"{path}: not valid JSON (not UTF-8 text)") from None
    try:
        return _expand(path, raw, out, check_clips)
    except (_SpecError, UserError) as err:
        raise UserError(f"{path}: {err}") from None


def _expand(path: Path, raw: Any, out: str | Path | None, check_clips: bool) -> Spec:
    if not isinstance(raw, dict):
        raise _SpecError("expected a JSON object at the top level")
    unknown = [k for k in raw if k not in SPEC_FIELDS]
    if unknown:
        raise _SpecError(f"unknown field {unknown[0]!r} (fields: {', '.join(SPEC_FIELDS)})")

    name = raw.get("name", path.stem)
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9._-]+", name) or name in (".", ".."):
        raise _SpecError(f"name {name!r}: use letters, digits, '.', '_' and '-' only")
    description = raw.get("description", "")
    if not isinstance(description, str):
        raise _SpecError("description: expected a string")
    preset = raw.get("preset", "gpu")
    if preset not in config_lib.PRESETS:
        raise _SpecError(f"preset {preset!r} does not exist (presets: {', '.join(config_lib.PRESETS)})")

    if "clip" in raw and "clips" in raw:
        raise _SpecError("give either \"clip\" or \"clips\", not both")
    if "clip" in raw:
        clips = [raw["clip"]]
    elif "clips" in raw:
        clips = raw["clips"]
        if not isinstance(clips, list) or not clips:
            raise _SpecError("clips: expected a non-empty list of clip names or paths")
    else:
        clips = [config_lib.make_config(preset).clip.name]
    for clip in clips:
        if not isinstance(clip, str) or not clip.strip():
            raise _SpecError(f"clips: {json.dumps(clip)} is not a clip name or path")
    if len(set(clips)) != len(clips):
        raise _SpecError("clips: a clip is listed twice")

    seeds = raw.get("seeds", [0])
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        seeds = [seeds]
    if (not isinstance(seeds, list) or not seeds
            or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds)):
        raise _SpecError("seeds: expected a non-empty list of non-negative integers")
    if len(set(seeds)) != len(seeds):
        raise _SpecError("seeds: a seed is listed twice")

    common = _overrides(raw.get("set", {}), "set")

    grid: dict[str, list] = {}
    if "grid" in raw:
        if not isinstance(raw["grid"], dict):
            raise _SpecError("grid: expected an object of section.key: [values]")
        if not raw["grid"]:
            raise _SpecError("grid is empty (leave it out, or give at least one key with values)")
        for key, values in raw["grid"].items():
            _check_key(key, "grid")
            if not isinstance(values, list) or not values:
                raise _SpecError(f"grid: config key {key!r}: expected a non-empty list of values")
            for v in values:
                _overrides({key: v}, "grid")
            if len({cli_value(v) for v in values}) != len(values):
                raise _SpecError(f"grid: config key {key!r}: a value is listed twice")
            if key in common:
                raise _SpecError(f"config key {key!r} is in both \"set\" and \"grid\"")
            grid[key] = values

    entries: list[dict[str, Any]] = [{}]
    entry_labels: list[str | None] = [None]
    if "runs" in raw:
        if not isinstance(raw["runs"], list) or not raw["runs"]:
            raise _SpecError("runs: expected a non-empty list of override objects")
        labelled = [_runs_entry(e, f"runs[{i}]") for i, e in enumerate(raw["runs"])]
        entry_labels = [label for label, _ in labelled]
        entries = [entry for _, entry in labelled]
        given = [label for label in entry_labels if label is not None]
        if len(set(given)) < len(given):
            raise _SpecError('runs: two entries have the same "label"')
        for i, entry in enumerate(entries):
            for key in entry:
                if key in common:
                    raise _SpecError(f"config key {key!r} is in both \"set\" and runs[{i}]")
                if key in grid:
                    raise _SpecError(f"config key {key!r} is in both \"grid\" and runs[{i}]")

    out_dir = out if out is not None else raw.get("out", f"runs/sweeps/{name}")
    if not isinstance(out_dir, (str, Path)) or not str(out_dir).strip():
        raise _SpecError("out: expected a folder path")

    if check_clips:
        from mjxmimic.motion.clip import resolve_clip

        for clip in clips:
            try:
                resolve_clip(clip)
            except UserError as err:
                raise _SpecError(f"clips: {err}") from None

    keys = list(grid)
    combos = list(itertools.product(*(grid[k] for k in keys))) if keys else [()]
    # Which keys vary (named in run names), and which of them share a last part (then: full key).
    varying = list(dict.fromkeys(keys + [k for e in entries for k in e]))
    last = [k.split(".")[1] for k in varying]
    label_key = {k: (k.split(".")[1] if last.count(k.split(".")[1]) == 1 else k) for k in varying}

    runs: list[RunSpec] = []
    seen: dict[str, str] = {}
    for si, seed in enumerate(seeds):
        for ci, clip in enumerate(clips):
            for gi, combo in enumerate(combos):
                for ei, entry in enumerate(entries):
                    own = {**dict(zip(keys, combo)), **entry}
                    args = {k: cli_value(v) for k, v in {**common, **own}.items()}
                    named = own if entry_labels[ei] is None else dict(zip(keys, combo))
                    parts = [f"{label_key[k]}={_label_value(v)}" for k, v in named.items()]
                    if entry_labels[ei] is not None:
                        parts.append(entry_labels[ei])
                    label = "-".join([clip_label(clip)] + parts + [f"s{seed}"])
                    label = _SAFE.sub("_", label).strip("._") or "run"
                    identity = json.dumps([clip, sorted(args.items()), seed])
                    if identity in seen:
                        raise _SpecError(f"run {label} comes twice (a grid value or runs entry is repeated)")
                    seen[identity] = label
                    try:
                        cfg = config_lib.make_config(preset, {**args, "clip.name": clip, "run.seed": str(seed)})
                    except UserError as err:
                        raise _SpecError(f"{_origin(str(err), common, grid, ei, entry)}{err} (in run {label})") from None
                    except (TypeError, ValueError) as err:
                        raise _SpecError(f"a config value has the wrong type: {err} (in run {label})") from None
                    runs.append(RunSpec(name=label, clip=clip, seed=seed, overrides=own, args=args,
                                        config=cfg, order=(ci, gi, ei, si)))

    # Unique, bounded names: a short hash where names collide or are too long.
    counts: dict[str, int] = {}
    for r in runs:
        counts[r.name] = counts.get(r.name, 0) + 1
    fixed = []
    for r in runs:
        name_ = r.name
        if counts[name_] > 1 or len(name_) > MAX_NAME:
            h = _short_hash([r.clip, sorted(r.args.items()), r.seed])
            name_ = f"{name_[:MAX_NAME - 9]}-{h}"
        fixed.append(dataclasses.replace(r, name=name_))

    return Spec(path=path, name=name, description=description, preset=preset, clips=clips, seeds=seeds,
                common=common, grid=grid, entries=entries if "runs" in raw else [], out=Path(out_dir),
                runs=fixed, raw=raw, ray=_ray_block(raw.get("ray", {}), fixed))


def select_runs(spec: Spec, patterns: str) -> Spec:
    """The spec with only the runs whose names match one of the comma-separated shell patterns."""
    wanted = [p.strip() for p in patterns.split(",") if p.strip()]
    runs = [r for r in spec.runs if any(fnmatch.fnmatchcase(r.name, p) for p in wanted)]
    if not runs:
        names = ", ".join(r.name for r in spec.runs)
        raise UserError(f"--only {patterns}: matches none of the runs of {spec.path} ({names})")
    return dataclasses.replace(spec, runs=runs)
