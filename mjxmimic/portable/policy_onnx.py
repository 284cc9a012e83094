"""The policy file as ONNX (optional, needs the `onnx` package): the graph computes the
deterministic action, and the manifest, the character XML and the clips ride in its metadata
(mjxmimic.portable.policy_file has the contents and the npz format)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mjxmimic import __version__
from mjxmimic.core.errors import UserError
from mjxmimic.portable.policy_file import PolicyFile, params_from_arrays, parse_manifest


def onnx_package():
    try:
        import onnx
    except ImportError:
        raise UserError("--format onnx needs the 'onnx' package (pip install onnx)") from None
    return onnx


def _mlp_nodes(helper, numpy_helper, net: dict, prefix: str, h: str) -> tuple[str, list, list]:
    """(output name, initializers, nodes) of one MLP: relu after every layer but the last."""
    inits, nodes = [], []
    for i in range(len(net)):
        name = f"hidden_{i}"
        kernel, bias, out = f"{prefix}/{name}/kernel", f"{prefix}/{name}/bias", f"{prefix}/{name}/out"
        inits += [numpy_helper.from_array(np.asarray(net[name]["kernel"], np.float32), kernel),
                  numpy_helper.from_array(np.asarray(net[name]["bias"], np.float32), bias)]
        nodes += [helper.make_node("MatMul", [h, kernel], [f"{prefix}/{name}/mm"]),
                  helper.make_node("Add", [f"{prefix}/{name}/mm", bias], [out])]
        h = out
        if i < len(net) - 1:
            nodes.append(helper.make_node("Relu", [h], [f"{prefix}/{name}/relu"]))
            h = f"{prefix}/{name}/relu"
    return h, inits, nodes


def to_onnx(pf: PolicyFile):
    """An onnx.ModelProto of the deterministic policy, with the manifest in its metadata."""
    onnx = onnx_package()
    from onnx import TensorProto, helper, numpy_helper

    policy = pf.policy()
    if policy.encoder:
        raise UserError("ONNX export covers MLP policies; a terrain policy's heightmap encoder is not written "
                        "to ONNX yet (use the npz file)")
    obs, act = policy.observation_size, policy.action_size
    inits = [numpy_helper.from_array(np.asarray(pf.params["normalizer"][k], np.float32), f"normalizer/{k}")
             for k in ("mean", "std")]
    nodes = [helper.make_node("Sub", ["obs", "normalizer/mean"], ["centred"]),
             helper.make_node("Div", ["centred", "normalizer/std"], ["h_in"])]
    h, more, extra = _mlp_nodes(helper, numpy_helper, pf.params["policy"], "policy", "h_in")
    inits += more
    nodes += extra
    inits += [numpy_helper.from_array(np.array([0], np.int64), "slice/start"),
              numpy_helper.from_array(np.array([act], np.int64), "slice/end"),
              numpy_helper.from_array(np.array([-1], np.int64), "slice/axis")]
    nodes += [helper.make_node("Slice", [h, "slice/start", "slice/end", "slice/axis"], ["loc"]),
              helper.make_node("Tanh", ["loc"], ["action"])]
    outputs = [helper.make_tensor_value_info("action", TensorProto.FLOAT, ["N", act])]
    if pf.has_value():  # V(obs) as a second output, [N, 1]
        v, more, extra = _mlp_nodes(helper, numpy_helper, pf.params["value"], "value", "h_in")
        inits += more
        nodes += [*extra, helper.make_node("Identity", [v], ["value"])]
        outputs.append(helper.make_tensor_value_info("value", TensorProto.FLOAT, ["N", 1]))
    graph = helper.make_graph(
        nodes, "mjxmimic_policy",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, ["N", obs])],
        outputs, initializer=inits)
    model = helper.make_model(graph, producer_name="mjxmimic", producer_version=__version__,
                              opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    def as_json(qpos: np.ndarray, durations: np.ndarray) -> dict[str, list]:
        return {"qpos": np.asarray(qpos, np.float64).tolist(), "durations": np.asarray(durations, np.float64).tolist()}

    meta = [("mjxmimic/manifest", json.dumps(pf.manifest)), ("mjxmimic/character_xml", pf.character_xml),
            ("mjxmimic/clip", json.dumps(as_json(pf.clip_qpos, pf.clip_durations)))]
    if pf.other_clips:
        meta.append(("mjxmimic/clips", json.dumps([as_json(q, d) for q, d in pf.other_clips])))
    for key, value in meta:
        entry = model.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.checker.check_model(model)
    return model


def write_onnx(pf: PolicyFile, path: Path) -> Path:
    """Write atomically, like `write_npz`."""
    onnx = onnx_package()
    model = to_onnx(pf)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    onnx.save(model, str(tmp))
    tmp.replace(path)
    return path


def read_onnx(path: Path) -> PolicyFile:
    """An ONNX policy file written by `write_onnx` (the manifest, XML and clip from its metadata)."""
    onnx = onnx_package()
    from onnx import numpy_helper

    path = Path(path)
    try:
        model = onnx.load(str(path))
    except Exception as err:  # noqa: BLE001 (onnx raises several kinds)
        raise UserError(f"{path}: cannot read as an ONNX policy file ({err})") from None
    meta = {p.key: p.value for p in model.metadata_props}
    for key in ("mjxmimic/manifest", "mjxmimic/character_xml", "mjxmimic/clip"):
        if key not in meta:
            raise UserError(f"{path}: not an mjxmimic ONNX policy (no '{key}' metadata)")
    manifest = parse_manifest(meta["mjxmimic/manifest"], path)
    tensors = {t.name: numpy_helper.to_array(t) for t in model.graph.initializer}
    clips = [json.loads(meta["mjxmimic/clip"]), *json.loads(meta.get("mjxmimic/clips", "[]"))]
    arrays = [(np.asarray(c["qpos"], np.float64), np.asarray(c["durations"], np.float64)) for c in clips]
    return PolicyFile(manifest=manifest, params=params_from_arrays(tensors), character_xml=meta["mjxmimic/character_xml"],
                      clip_qpos=arrays[0][0], clip_durations=arrays[0][1], other_clips=arrays[1:], path=path)
