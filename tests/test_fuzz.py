"""Fuzzed input for the parsers a user feeds: any clip, dataset, config override, sweep spec or
BVH file gives a result or a one-line UserError, never another exception (a traceback)."""

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError

SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12))
json_values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=6),
                                                            st.dictionaries(st.text(max_size=8), inner, max_size=6)),
                           max_leaves=40)
frames = st.lists(st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 5)),
                           min_size=0, max_size=50), max_size=6)
# frames of the humanoid's width (44 numbers: duration, root, 12 joints), any values: the paths past
# the shape checks (durations, quaternions of zeros, NaN, huge numbers)
humanoid_frames = st.lists(st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32),
                                              st.sampled_from([0.0, 1.0, -1.0, 1e30])),
                                    min_size=44, max_size=44), min_size=1, max_size=5)
clip_like = st.one_of(json_values, st.fixed_dictionaries(
    {"Loop": st.one_of(st.sampled_from(["wrap", "none"]), scalars),
     "Frames": st.one_of(frames, humanoid_frames, json_values)}))


def _one_line(err: UserError) -> None:
    assert "\n" not in str(err) and str(err)


@SETTINGS
@given(data=clip_like)
def test_any_clip_json_loads_or_is_one_line(character, data):
    from mjxmimic.motion.clip import clip_from_json

    try:
        clip_from_json(data, character)
    except UserError as err:
        _one_line(err)


@SETTINGS
@given(data=st.one_of(json_values, st.fixed_dictionaries({"clips": json_values})))
def test_any_dataset_loads_or_is_one_line(character, tmp_path, data):
    from mjxmimic.motion.dataset import load_dataset

    path = tmp_path / "set.json"
    path.write_text(json.dumps(data))
    try:
        load_dataset(path, character)
    except UserError as err:
        _one_line(err)


keys = st.one_of(st.text(max_size=20),
                 st.sampled_from([f"{section}.{f}" for section, values in config_lib.to_dict(config_lib.Config()).items()
                                  for f in values]))


@SETTINGS
@given(key=keys, value=st.one_of(st.text(max_size=20), scalars))
def test_any_config_override_applies_or_is_one_line(key, value):
    try:
        config_lib.apply_overrides(config_lib.Config(), {key: value if isinstance(value, str) else str(value)})
    except UserError as err:
        _one_line(err)


@SETTINGS
@given(data=st.one_of(json_values, st.fixed_dictionaries({"preset": st.sampled_from(["cpu", "gpu"]),
                                                          "clips": json_values, "grid": json_values})))
def test_any_sweep_spec_loads_or_is_one_line(tmp_path, data):
    from mjxmimic.ops.sweep import load_spec

    path = tmp_path / "spec.json"
    path.write_text(json.dumps(data))
    try:
        load_spec(path)
    except UserError as err:
        _one_line(err)


@pytest.mark.parametrize("text", ["", "{", "[1, 2", "\x00\x01", "nan"])
def test_broken_files(character, tmp_path, text):
    from mjxmimic.motion.clip import load_clip

    path = tmp_path / "clip.txt"
    path.write_text(text)
    with pytest.raises(UserError):
        load_clip(path, character)


# A BVH file of tests/test_bvh.py's walk under random edits: words replaced by other words or
# numbers, lines dropped, the file cut short; joint names renamed at random (the mapping's guess).
bvh_edits = st.lists(st.tuples(st.floats(0, 1, exclude_max=True),
                               st.one_of(st.none(), st.text(max_size=10),
                                         st.sampled_from(["0", "-1", "1e9", "nan", "{", "}", "JOINT", "End",
                                                          "lThigh", "UpperLeg_L", "Head", "mixamorig:Hips"]))),
                     max_size=6)


@SETTINGS
@given(edits=bvh_edits, cut=st.one_of(st.none(), st.floats(0, 1)))
def test_any_bvh_file_imports_or_is_one_line(character, edits, cut):
    from pathlib import Path

    from test_bvh import bvh_text, walking_frames

    from mjxmimic.motion.bvh import parse_bvh
    from mjxmimic.motion.bvh_import import find_mapping, import_bvh

    words = bvh_text(walking_frames(0.3)).replace("\n", " \n ").split(" ")
    for where, word in edits:
        words[int(where * len(words))] = "" if word is None else word
    text = " ".join(words)
    if cut is not None:
        text = text[:int(cut * len(text))]
    try:
        bvh = parse_bvh(text, Path("fuzz.bvh"))
        import_bvh(bvh, character, find_mapping(bvh, "humanoid"), fps=30)
    except UserError as err:
        _one_line(err)
