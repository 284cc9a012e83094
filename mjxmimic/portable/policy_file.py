"""One portable policy file: everything CPU playback needs, and nothing it must look up elsewhere.

npz format (`numpy.load(path)`, no pickles), format "mjxmimic-policy" version 1. Keys:

    manifest                    0-d str: JSON (below)
    character_xml               0-d str: the character's MJCF text itself
    normalizer/mean             (obs,)  float32   z = (obs - mean) / std, no clipping
    normalizer/std              (obs,)  float32
    policy/hidden_<i>/kernel    (in, out) float32 for i = 0 .. L: relu after every layer but the
    policy/hidden_<i>/bias      (out,)  float32   last; the last has 2 * action_size outputs
                                                  (loc, scale); the action is tanh(loc)
    value/hidden_<i>/kernel     (in, out) float32 the value network (the same normaliser, relu after
    value/hidden_<i>/bias       (out,)  float32   every layer but the last, which has 1 output: V);
                                                  absent from files exported before it was carried
    clip/qpos                   (frames, nq) float64  the reference clip, MuJoCo qpos layout, z-up
    clip/durations              (frames,) float64     seconds from each frame to the next
    clip/<i>/qpos, .../durations                      a dataset's clips after the first (i = 1 ..)

The manifest (JSON object):
    format, format_version, mjxmimic_version, created (UTC, ISO 8601)
    character   file name, sha256 of character_xml (UTF-8 bytes), nq, nv, nbody, action_size, and
                every actuated joint in clip order with kind, kp, kd (= MuJoCo damping),
                torque_limit and (hinges) range: the PD gains and limits as derived from the MJCF
    clip        name, source path at export time, loop, frames, duration_s
    dataset     (a policy trained on several clips) name and clips: each clip's name, loop,
                frames, duration_s and weight, in the order of the skill one-hot
    control     control_hz, physics_hz, substeps, solver_iterations, ls_iterations, integrator,
                action_mode, action_scale, action (what an action means), pd_law
    episode     episode_seconds, early_termination, max_joint_velocity, fall_contact (resolved
                body set) and fall_bodies (body names)
    reward      kind
    observation size and layout (ordered parts with sizes and the bodies they run over)
    policy      hidden_sizes, activation, output, normalizer, dtype
    value       (when the value network is carried) hidden_sizes, output, normalizer, discount
    training    run folder, checkpoint (env_steps), best (whether it is the run's best-evaluated
                checkpoint), samples, train_seconds, and `eval`: the training-side (MJX)
                evaluation of that checkpoint: nr, fall_rate, survival_s, episodes, seed and the
                start times of its episodes (so CPU playback starts from the same RSI states);
                for a dataset also `clips`: each clip's nr and start times
    config      the run's resolved config (mjxmimic.core.config.to_dict); playback rebuilds its
                environment settings from it (character and clip come from this file instead)
    arrays      every array key with its shape and dtype

ONNX (mjxmimic.portable.policy_onnx; optional, needs the `onnx` package): graph input "obs"
[N, obs] float32, output "action" [N, act] = tanh(loc) (and "value" [N, 1] where the value network
is carried), the normaliser and the MLPs as ONNX nodes;
the manifest, the character XML and the clips ride in the model's metadata_props ("mjxmimic/manifest", "mjxmimic/character_xml",
"mjxmimic/clip", and "mjxmimic/clips" for a dataset's others), so an .onnx file plays back as well.

No JAX here (numpy and mujoco; onnx for .onnx files), so that `mjxmimic play` and `render` run
without it; writing one from a run's checkpoint is mjxmimic.runs.export's job.
"""

from __future__ import annotations

import atexit
import dataclasses
import datetime
import hashlib
import json
import shutil
import tempfile
import zipfile
import zlib
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from mjxmimic import __version__
from mjxmimic.core import config as config_lib
from mjxmimic.core.character import BALL, Character, default_fall_contact, load_character
from mjxmimic.core.errors import UserError
from mjxmimic.portable.policy_numpy import NumpyPolicy, NumpyValue, ordered_layers

FORMAT = "mjxmimic-policy"
FORMAT_VERSION = 1
FORMATS = ("npz", "onnx")
NETWORKS = ("policy", "value")  # array name prefixes of the networks' layers


# ---------------------------------------------------------------------------------- the contents


@dataclasses.dataclass
class PolicyFile:
    """The contents of an exported policy (either format)."""

    manifest: dict[str, Any]
    params: dict[str, Any]  # {"normalizer": {"mean", "std"}, "policy": {"hidden_i": {"kernel", "bias"}},
    #                          and "value" (the same layout) where the file carries the value network}
    character_xml: str
    clip_qpos: np.ndarray
    clip_durations: np.ndarray
    other_clips: list[tuple[np.ndarray, np.ndarray]] = dataclasses.field(default_factory=list)  # (qpos, durations)
    path: Path | None = None
    _character: Character | None = dataclasses.field(default=None, repr=False)

    def policy(self) -> NumpyPolicy:
        """The deterministic policy as a numpy function."""
        return NumpyPolicy.from_params(self.params, _heightmap_shape(self.config()))

    def has_value(self) -> bool:
        return bool(self.params.get("value"))

    def value(self) -> NumpyValue:
        """The value network V(obs) as a numpy function (UserError when the file lacks it)."""
        if not self.has_value():
            raise UserError(f"{self.path}: the policy file lacks its value network (exported before it was "
                            f"carried); re-export it with `mjxmimic export RUN`")
        return NumpyValue(self.params, _heightmap_shape(self.config()))

    def config(self) -> config_lib.Config:
        """The run's config (playback rebuilds its environment settings from it)."""
        return config_lib.from_dict(self.manifest["config"])

    def character(self) -> Character:
        """The character, loaded from the embedded MJCF text (checked against its sha256)."""
        if self._character is None:
            digest = _sha256(self.character_xml)
            want = self.manifest["character"]["sha256"]
            if digest != want:
                raise UserError(f"{self.path}: the embedded character XML does not match its sha256 "
                                f"(file {digest[:12]}..., manifest {want[:12]}...)")
            name = Path(self.manifest["character"]["file"]).name or "character.xml"
            # The file stays for the life of the process (Character.sha256 reads it again).
            tmp = tempfile.mkdtemp(prefix="mjxmimic-character-")
            atexit.register(shutil.rmtree, tmp, True)
            xml_path = Path(tmp) / name
            xml_path.write_text(self.character_xml, encoding="utf-8")
            self._character = load_character(xml_path)
        return self._character

    def clip(self):
        """The embedded reference clip (a dataset's first) as an mjxmimic.motion.clip.Clip."""
        return self.clips()[0]

    def clips(self) -> list:
        """Every embedded clip (several for a policy trained on a dataset), in skill order."""
        from mjxmimic.motion.clip import Clip

        entries = self.manifest["dataset"]["clips"] if "dataset" in self.manifest else [self.manifest["clip"]]
        arrays = [(self.clip_qpos, self.clip_durations), *self.other_clips]
        if len(arrays) != len(entries):
            raise UserError(f"{self.path}: the manifest lists {len(entries)} clips, the file holds {len(arrays)}")
        return [Clip(name=c["name"], path=None, loop=bool(c["loop"]), durations=np.array(d, np.float64),
                     qpos=np.array(q, np.float64)) for c, (q, d) in zip(entries, arrays, strict=True)]

    def weights(self) -> list[float] | None:
        return [c["weight"] for c in self.manifest["dataset"]["clips"]] if "dataset" in self.manifest else None

    def arrays(self) -> dict[str, np.ndarray]:
        """Every array under its npz key."""
        out = {"normalizer/mean": np.asarray(self.params["normalizer"]["mean"]),
               "normalizer/std": np.asarray(self.params["normalizer"]["std"])}
        for net in NETWORKS:
            for name, layer in (self.params.get(net) or {}).items():
                out[f"{net}/{name}/kernel"] = np.asarray(layer["kernel"])
                out[f"{net}/{name}/bias"] = np.asarray(layer["bias"])
        out["clip/qpos"] = np.asarray(self.clip_qpos)
        out["clip/durations"] = np.asarray(self.clip_durations)
        for i, (qpos, durations) in enumerate(self.other_clips, start=1):
            out[f"clip/{i}/qpos"], out[f"clip/{i}/durations"] = np.asarray(qpos), np.asarray(durations)
        return out


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


# -------------------------------------------------------------------------------- the manifest


def observation_layout(character: Character, config: config_lib.Config | None = None,
                       clip_names: list[str] | None = None) -> list[dict[str, Any]]:
    """The observation's parts in order (mjxmimic.task.observation's terms as `env.observations`
    names them, then the task's goal), with sizes."""
    from mjxmimic.task import goals, observation

    bodies = list(character.body_names)
    n = len(bodies)
    frame = "heading frame (rotation about z that undoes the root's facing)"
    if config is not None and config.env.observation_heading == "twist":
        frame = "heading frame (rotation about z that undoes the twist of the root's rotation about z)"
    parts = {
        "phase": [{"name": "phase", "size": 1, "about": "clip phase in [0, 1)"}],
        "root_height": [{"name": "root_height", "size": 1, "about": "root body centre-of-mass height, world z (m)"}],
        "bodies": [
            {"name": "body_position", "size": 3 * n, "bodies": bodies,
             "about": f"body centre of mass minus the root's, {frame}"},
            {"name": "body_forward", "size": 3 * n, "bodies": bodies, "about": f"body x axis, {frame}"},
            {"name": "body_up", "size": 3 * n, "bodies": bodies, "about": f"body z axis, {frame}"},
            {"name": "body_linear_velocity", "size": 3 * n, "bodies": bodies,
             "about": f"centre-of-mass linear velocity, {frame}"},
            {"name": "body_angular_velocity", "size": 3 * n, "bodies": bodies, "about": f"angular velocity, {frame}"},
        ],
        "skill": [{"name": "skill", "size": len(clip_names or [None]), "clips": clip_names,
                   "about": "one-hot of the clip to follow (the skill selector), in the order of `clips`"}],
        "reference_root": [{"name": "reference_root", "size": 4,
                            "about": "the reference root's horizontal offset from the root (m), root heading "
                                     "frame, then sin and cos of the reference's heading minus the root's"}],
    }
    names = observation.parse(config.env.observations if config is not None else observation.DEFAULT)
    out = [part for name in names for part in parts[name]]
    task = config.task.name if config is not None else ""
    if goals.GOAL_SIZE[task]:
        out.append({"name": "goal", "size": goals.GOAL_SIZE[task], "about": f"the {task} task's goal (mjxmimic.task.goals)"})
    shape = _heightmap_shape(config) if config is not None else None
    if shape is not None:
        out.append({"name": "heightmap", "size": shape[0] * shape[1],
                    "about": f"terrain heights minus the root's on a {shape[0]} x {shape[1]} grid in the heading frame "
                             "(mjxmimic.core.terrain.heightmap), rows along the facing"})
    return out


def _joints(character: Character) -> list[dict[str, Any]]:
    model = character.model
    out = []
    for j in character.joints:
        entry = {"name": j.name, "kind": j.kind, "kp": j.kp, "kd": j.kd, "torque_limit": j.torque_limit,
                 "pose_weight": j.weight}
        if j.kind != BALL:
            jid = model.dof_jntid[j.dof_adr]
            entry["range"] = [float(model.jnt_range[jid, 0]), float(model.jnt_range[jid, 1])]
        out.append(entry)
    return out


def _clip_entry(clip: Any) -> dict[str, Any]:
    return {"name": clip.name, "source": str(clip.path) if getattr(clip, "path", None) is not None else None,
            "loop": bool(clip.loop), "frames": int(clip.qpos.shape[0]),
            "duration_s": clip.duration}


def _heightmap_shape(config: config_lib.Config) -> tuple[int, ...] | None:
    """A terrain policy's heightmap (rows, cols): the last observation numbers, which its encoder reads."""
    return None if config.terrain.kind == "none" else tuple(config.terrain.heightmap_shape)


def build_manifest(config: config_lib.Config, character: Character, character_xml: str, clip: Any,
                   params: dict[str, Any], training: dict[str, Any] | None = None,
                   dataset: dict[str, Any] | None = None) -> dict[str, Any]:
    """The manifest (module docstring); checks that the policy's sizes fit the character."""
    env = config.env
    policy = NumpyPolicy.from_params(params, _heightmap_shape(config))
    clip_names = [c["name"] for c in dataset["clips"]] if dataset is not None else [clip.name]
    obs_layout = observation_layout(character, config, clip_names)
    obs_size = sum(p["size"] for p in obs_layout)
    if policy.observation_size != obs_size:
        raise UserError(f"the policy takes {policy.observation_size} observations; the character "
                        f"{character.xml_path.name} gives {obs_size}")
    if policy.action_size != character.action_size:
        raise UserError(f"the policy gives {policy.action_size} actions; the character "
                        f"{character.xml_path.name} has {character.action_size}")
    fall = config.clip.fall_contact
    if fall == "auto":
        fall = default_fall_contact(clip.name)
    try:
        fall_bodies = [character.body_names[b - 1] for b in character.fall_bodies(fall)]
    except ValueError as err:
        raise UserError(f"config key 'clip.fall_contact': {err}") from None
    integrator = mujoco.mjtIntegrator(int(character.model.opt.integrator)).name
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "mjxmimic_version": __version__,
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "character": {
            "file": character.xml_path.name,
            "sha256": _sha256(character_xml),
            "nq": int(character.nq), "nv": int(character.nv), "nbody": int(character.model.nbody),
            "action_size": int(character.action_size),
            "joints": _joints(character),
        },
        "clip": _clip_entry(clip),
        **({"dataset": dataset} if dataset is not None else {}),
        "control": {
            "control_hz": env.control_hz,
            "physics_hz": env.physics_hz,
            "substeps": env.physics_hz // env.control_hz,
            "solver_iterations": env.solver_iterations,
            "ls_iterations": env.ls_iterations,
            "integrator": integrator,
            "action_mode": env.action_mode,
            "action_scale": env.action_scale,
            "action": ("28 numbers in [-1, 1] in clip joint order: an exponential map per ball joint, "
                       "an angle per hinge; mjxmimic.physics.pd.action_to_targets").replace(
                           "28", str(character.action_size)),
            "torque_limit": env.torque_limit,
            "pd_law": ("per physics substep: tau = kp (target - (q + dt qdot)); damping kd is the "
                       "joint's MuJoCo damping; torque_limit 'total': qfrc_applied = clamp(tau - kd "
                       "qdot) + kd qdot, 'proportional': clamp(tau); mjxmimic.physics.pd.pd_forces"),
        },
        "episode": {
            "episode_seconds": env.episode_seconds,
            "early_termination": env.early_termination,
            "max_joint_velocity": env.max_joint_velocity,
            "fall_contact": fall,
            "fall_bodies": fall_bodies,
        },
        "reward": {"kind": config.reward.kind},
        "observation": {"size": obs_size, "layout": obs_layout},
        "policy": {
            "hidden_sizes": list(policy.hidden_sizes),
            "activation": "relu",
            "output": "2 * action_size numbers (loc, scale); deterministic action = tanh(loc)",
            "normalizer": "(obs - mean) / std, no clipping",
            "dtype": "float32",
        },
        **({"value": _value_entry(config, params)} if params.get("value") else {}),
        "training": training or {},
        "config": config_lib.to_dict(config),
    }


def _value_entry(config: config_lib.Config, params: dict[str, Any]) -> dict[str, Any]:
    layers = ordered_layers(params, "value")
    return {"hidden_sizes": [int(b.shape[0]) for _, b in layers[:-1]],
            "output": "1 number: the state value, the discounted return the policy expects from here",
            "normalizer": "the policy's: (obs - mean) / std, no clipping",
            "discount": config.ppo.discounting}


def make_policy_file(config: config_lib.Config, character: Character, clips: Any, params: dict[str, Any],
                     training: dict[str, Any] | None = None, weights: list[float] | None = None) -> PolicyFile:
    """Assemble the contents from in-memory parts (params as `mjxmimic.learn.ppo.export_params`);
    `clips` is one clip, or a dataset's clips (in skill order) with their weights."""
    clips = list(clips) if isinstance(clips, (list, tuple)) else [clips]
    clip = clips[0]
    dataset = None
    if len(clips) > 1 or weights is not None:
        weights = list(weights) if weights is not None else [1.0] * len(clips)
        dataset = {"name": config.clip.name,
                   "clips": [dict(_clip_entry(c), weight=float(w)) for c, w in zip(clips, weights, strict=True)]}
    xml = Path(character.xml_path).read_text(encoding="utf-8")
    try:
        mujoco.MjModel.from_xml_string(xml)
    except ValueError as err:
        raise UserError(f"{character.xml_path}: the character does not compile on its own, without "
                        f"its folder (does it use other files?): {err}") from None
    params = _as_numpy(params)
    manifest = build_manifest(config, character, xml, clip, params, training, dataset)
    pf = PolicyFile(manifest=manifest, params=params, character_xml=xml,
                    clip_qpos=np.asarray(clip.qpos, np.float64), clip_durations=np.asarray(clip.durations, np.float64),
                    other_clips=[(np.asarray(c.qpos, np.float64), np.asarray(c.durations, np.float64))
                                 for c in clips[1:]])
    manifest["arrays"] = {k: {"shape": list(v.shape), "dtype": str(v.dtype)} for k, v in pf.arrays().items()}
    pf.manifest = json.loads(json.dumps(manifest))  # as a reader will see it (tuples become lists)
    return pf


def _as_numpy(params: dict[str, Any]) -> dict[str, Any]:
    out = {"normalizer": {k: np.asarray(params["normalizer"][k], np.float32) for k in ("mean", "std")}}
    for net in NETWORKS:
        if params.get(net):
            out[net] = {name: {k: np.asarray(layer[k], np.float32) for k in ("kernel", "bias")}
                        for name, layer in params[net].items()}
    return out


# ------------------------------------------------------------------------------------ npz files


def write_npz(pf: PolicyFile, path: Path) -> Path:
    arrays = pf.arrays()
    arrays["manifest"] = np.array(json.dumps(pf.manifest, indent=1))
    arrays["character_xml"] = np.array(pf.character_xml)
    return save_arrays(arrays, path)


def save_arrays(arrays: dict[str, np.ndarray], path: Path) -> Path:
    """A compressed npz written atomically (a temporary file renamed into place): nothing half-written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        np.savez_compressed(f, **arrays)
    tmp.replace(path)
    return path


def parse_manifest(text: str, path: Path) -> dict[str, Any]:
    try:
        manifest = json.loads(text)
    except json.JSONDecodeError as err:
        raise UserError(f"{path}: the manifest is not valid JSON ({err.msg})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise UserError(f"{path}: not an mjxmimic policy file (no '{FORMAT}' manifest)")
    version = manifest.get("format_version")
    if not isinstance(version, int) or version > FORMAT_VERSION:
        raise UserError(f"{path}: policy file format version {version} is newer than this mjxmimic "
                        f"reads ({FORMAT_VERSION}); update mjxmimic")
    return manifest


def params_from_arrays(arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """The nested params back from their flat array names (the same names in npz and ONNX)."""
    nets: dict[str, dict[str, dict[str, np.ndarray]]] = {net: {} for net in NETWORKS}
    for key, value in arrays.items():
        net, _, rest = key.partition("/")
        if net in nets and rest.count("/") == 1:
            layer, part = rest.split("/")
            nets[net].setdefault(layer, {})[part] = value
    out = {"normalizer": {"mean": arrays["normalizer/mean"], "std": arrays["normalizer/std"]},
           "policy": nets["policy"]}
    if nets["value"]:
        out["value"] = nets["value"]
    return out


# what np.load raises for a file that is not a whole npz (not a zip, cut short, corrupted)
UNREADABLE_NPZ = (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error)


def load_arrays(path: Path, what: str = "an npz policy file") -> dict[str, np.ndarray]:
    """Every array of an npz file (no pickles); a one-line UserError when it cannot be read.
    An npz is a zip archive: anything else (a text file, a .npy, one cut short) is named as such
    up front, as np.load would try it as a pickle and answer with a hint to load it unsafely."""
    if Path(path).is_file() and not zipfile.is_zipfile(path):
        raise UserError(f"{path}: cannot read as {what} (not a whole npz archive: another kind of "
                        "file, or one cut short)")
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except UNREADABLE_NPZ as err:
        raise UserError(f"{path}: cannot read as {what} ({err})") from None


def read_npz(path: Path) -> PolicyFile:
    """An npz policy file; anything else is a one-line UserError."""
    path = Path(path)
    data = load_arrays(path)
    for key in ("manifest", "character_xml", "normalizer/mean", "normalizer/std", "clip/qpos", "clip/durations"):
        if key not in data:
            raise UserError(f"{path}: not an mjxmimic policy file (no '{key}' array)")
    manifest = parse_manifest(str(data["manifest"]), path)
    others = []
    while f"clip/{len(others) + 1}/qpos" in data:
        i = len(others) + 1
        if f"clip/{i}/durations" not in data:
            raise UserError(f"{path}: not an mjxmimic policy file (no 'clip/{i}/durations' array)")
        others.append((data[f"clip/{i}/qpos"], data[f"clip/{i}/durations"]))
    return PolicyFile(manifest=manifest, params=params_from_arrays(data), character_xml=str(data["character_xml"]),
                      clip_qpos=data["clip/qpos"], clip_durations=data["clip/durations"], other_clips=others,
                      path=path)


# -------------------------------------------------------------------------------- either format


def check_format(fmt: str) -> None:
    """A one-line error for an unknown format, or for onnx without its package (before slow work)."""
    if fmt not in FORMATS:
        raise UserError(f"--format {fmt!r}: expected one of {', '.join(FORMATS)}")
    if fmt == "onnx":
        from mjxmimic.portable import policy_onnx

        policy_onnx.onnx_package()


def write(pf: PolicyFile, path: Path, fmt: str = "npz") -> Path:
    check_format(fmt)
    if fmt == "onnx":
        from mjxmimic.portable import policy_onnx

        return policy_onnx.write_onnx(pf, path)
    return write_npz(pf, path)


def read(path: str | Path) -> PolicyFile:
    """Read an exported policy file (.npz or .onnx); mjxmimic.runs.folder.load_policy_file also
    takes a run folder."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: policy file not found")
    if path.suffix == ".onnx":
        from mjxmimic.portable import policy_onnx

        return policy_onnx.read_onnx(path)
    return read_npz(path)
