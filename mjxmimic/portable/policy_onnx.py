"""The policy file as ONNX (optional, needs the `onnx` package): the graph computes the
deterministic action and, where the file carries it, the value (a terrain network's heightmap
encoder included); the manifest, the character XML and the clips ride in its metadata
(mjxmimic.portable.policy_file has the contents and the npz format)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mjxmimic import __version__
from mjxmimic.core.errors import UserError
from mjxmimic.portable.policy_file import PolicyFile, params_from_arrays, parse_manifest
from mjxmimic.portable.policy_numpy import HEIGHTMAP_STRIDES


def onnx_package():
    try:
        import onnx
    except ImportError:
        raise UserError("--format onnx needs the 'onnx' package (pip install onnx)") from None
    return onnx


def _dense(helper, numpy_helper, layer: dict, name: str, h: str, relu: bool) -> tuple[str, list, list]:
    """(output name, initializers, nodes) of h @ kernel + bias (then relu), the arrays under `name`."""
    kernel, bias = f"{name}/kernel", f"{name}/bias"
    inits = [numpy_helper.from_array(np.asarray(layer["kernel"], np.float32), kernel),
             numpy_helper.from_array(np.asarray(layer["bias"], np.float32), bias)]
    nodes = [helper.make_node("MatMul", [h, kernel], [f"{name}/mm"]),
             helper.make_node("Add", [f"{name}/mm", bias], [f"{name}/out"])]
    if relu:
        nodes.append(helper.make_node("Relu", [f"{name}/out"], [f"{name}/relu"]))
    return f"{name}/relu" if relu else f"{name}/out", inits, nodes


def _encoder_nodes(helper, numpy_helper, net: dict, prefix: str, z: str, obs_size: int,
                   heightmap_shape: tuple[int, int]) -> tuple[str, list, list]:
    """(output name, initializers, nodes) of a terrain network's heightmap encoder (policy_numpy's
    `encode`): [state, heightmap] -> [state, encoding]. The conv kernels keep Flax's (kh, kw, in,
    out) arrays under their names and are transposed to ONNX's (out, in, kh, kw) in the graph, so
    that reading the file back gives the npz file's arrays; SAME_UPPER padding is Flax's SAME."""
    rows, cols = heightmap_shape
    split = obs_size - rows * cols
    const = f"graph/{prefix}"
    values = {"start": [0], "split": [split], "end": [obs_size], "axis": [1], "grid": [-1, 1, rows, cols],
              "flat": [0, -1]}
    inits = [numpy_helper.from_array(np.array(v, np.int64), f"{const}/{k}") for k, v in values.items()]
    nodes = [helper.make_node("Slice", [z, f"{const}/start", f"{const}/split", f"{const}/axis"], [f"{const}/state"]),
             helper.make_node("Slice", [z, f"{const}/split", f"{const}/end", f"{const}/axis"], [f"{const}/map"]),
             helper.make_node("Reshape", [f"{const}/map", f"{const}/grid"], [f"{const}/x0"])]
    x = f"{const}/x0"
    for i, stride in enumerate(HEIGHTMAP_STRIDES):
        name = f"{prefix}/conv_{i}"
        kernel = np.asarray(net[f"conv_{i}"]["kernel"], np.float32)
        inits += [numpy_helper.from_array(kernel, f"{name}/kernel"),
                  numpy_helper.from_array(np.asarray(net[f"conv_{i}"]["bias"], np.float32), f"{name}/bias")]
        nodes += [helper.make_node("Transpose", [f"{name}/kernel"], [f"{name}/oihw"], perm=[3, 2, 0, 1]),
                  helper.make_node("Conv", [x, f"{name}/oihw", f"{name}/bias"], [f"{name}/out"],
                                   strides=[stride, stride], kernel_shape=list(kernel.shape[:2]), auto_pad="SAME_UPPER"),
                  helper.make_node("Relu", [f"{name}/out"], [f"{name}/relu"])]
        x = f"{name}/relu"
    nodes += [helper.make_node("Transpose", [x], [f"{const}/nhwc"], perm=[0, 2, 3, 1]),
              helper.make_node("Reshape", [f"{const}/nhwc", f"{const}/flat"], [f"{const}/flat_out"])]
    h, more, extra = _dense(helper, numpy_helper, net["encoder"], f"{prefix}/encoder", f"{const}/flat_out", True)
    nodes += [*extra, helper.make_node("Concat", [f"{const}/state", h], [f"{const}/joined"], axis=1)]
    return f"{const}/joined", inits + more, nodes


def _network_nodes(helper, numpy_helper, net: dict, prefix: str, z: str, obs_size: int,
                   heightmap_shape: tuple[int, int] | None) -> tuple[str, list, list]:
    """(output name, initializers, nodes) of one network on the normalised observation `z`: the
    heightmap encoder where it has one, then its MLP (relu after every layer but the last)."""
    h, inits, nodes = z, [], []
    if "encoder" in net:
        h, inits, nodes = _encoder_nodes(helper, numpy_helper, net, prefix, z, obs_size, heightmap_shape)
    count = sum(1 for name in net if name.startswith("hidden_"))
    for i in range(count):
        h, more, extra = _dense(helper, numpy_helper, net[f"hidden_{i}"], f"{prefix}/hidden_{i}", h, i < count - 1)
        inits += more
        nodes += extra
    return h, inits, nodes


def to_onnx(pf: PolicyFile):
    """An onnx.ModelProto of the deterministic policy, with the manifest in its metadata."""
    onnx = onnx_package()
    from onnx import TensorProto, helper, numpy_helper

    policy = pf.policy()
    obs, act = policy.observation_size, policy.action_size
    inits = [numpy_helper.from_array(np.asarray(pf.params["normalizer"][k], np.float32), f"normalizer/{k}")
             for k in ("mean", "std")]
    nodes = [helper.make_node("Sub", ["obs", "normalizer/mean"], ["centred"]),
             helper.make_node("Div", ["centred", "normalizer/std"], ["h_in"])]
    h, more, extra = _network_nodes(helper, numpy_helper, pf.params["policy"], "policy", "h_in", obs,
                                    policy.heightmap_shape)
    inits += more
    nodes += extra
    inits += [numpy_helper.from_array(np.array([0], np.int64), "slice/start"),
              numpy_helper.from_array(np.array([act], np.int64), "slice/end"),
              numpy_helper.from_array(np.array([-1], np.int64), "slice/axis")]
    nodes += [helper.make_node("Slice", [h, "slice/start", "slice/end", "slice/axis"], ["loc"]),
              helper.make_node("Tanh", ["loc"], ["action"])]
    outputs = [helper.make_tensor_value_info("action", TensorProto.FLOAT, ["N", act])]
    if pf.has_value():  # V(obs) as a second output, [N, 1]
        v, more, extra = _network_nodes(helper, numpy_helper, pf.params["value"], "value", "h_in", obs,
                                        policy.heightmap_shape)
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
