"""The trained policy's forward pass in numpy: no JAX, so an exported policy runs anywhere.

It is the function Brax's PPO networks compute (mjxmimic.learn.ppo, "Exported parameters"), written out:

    z   = (obs - mean) / std                        Brax running_statistics.normalize, no clipping
    h   = relu(z @ kernel_i + bias_i)               every hidden layer (Brax MLP "hidden_i")
    out = h @ kernel_L + bias_L                     the last layer, 2 * action_size numbers
    loc = out[:action_size]
    action = tanh(loc)                              NormalTanhDistribution.mode: the deterministic
                                                    (evaluation / playback) action, in [-1, 1]

A terrain policy (mjxmimic.learn.networks) first encodes the heightmap, the observation's last
rows x cols numbers (normalised like the rest): conv_0..2 (SAME padding, strides
HEIGHTMAP_STRIDES, relu), flattened, `encoder` (dense, relu), then [state, encoding] into the MLP.

The computation runs in float64 (the parameters are float32 as trained); the test suite checks
it against the JAX policy to 1e-5.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import numpy as np

_LAYER = re.compile(r"hidden_(\d+)$")
_ENCODER = ("conv_0", "conv_1", "conv_2", "encoder")
HEIGHTMAP_STRIDES = (2, 2, 1)  # mjxmimic.learn.networks.CONV_LAYERS (a test checks they agree)


def conv_same(x: np.ndarray, kernel: np.ndarray, bias: np.ndarray, stride: int) -> np.ndarray:
    """Flax's Conv with padding "SAME": x (..., H, W, Cin), kernel (kh, kw, Cin, Cout)."""
    kh, kw = kernel.shape[:2]
    pads = []
    for size, k in ((x.shape[-3], kh), (x.shape[-2], kw)):
        out = -(-size // stride)
        total = max((out - 1) * stride + k - size, 0)
        pads.append((total // 2, total - total // 2))
    x = np.pad(x, [(0, 0)] * (x.ndim - 3) + pads + [(0, 0)])
    oh, ow = -(-(x.shape[-3] - pads[0][0] - pads[0][1]) // stride), -(-(x.shape[-2] - pads[1][0] - pads[1][1]) // stride)
    out = np.zeros(x.shape[:-3] + (oh, ow, kernel.shape[-1]))
    for i in range(kh):
        for j in range(kw):
            patch = x[..., i: i + stride * (oh - 1) + 1: stride, j: j + stride * (ow - 1) + 1: stride, :]
            out += patch @ kernel[i, j]
    return out + bias


def ordered_layers(params: Mapping[str, Any], net: str) -> list[tuple[Any, Any]]:
    """[(kernel, bias)] of network `net` ("policy" or "value"), hidden_0 first."""
    tree = params[net]
    names = sorted((int(_LAYER.match(n).group(1)), n) for n in tree if _LAYER.match(n))
    encoder = [n for n in tree if n in _ENCODER]
    if [i for i, _ in names] != list(range(len(names))) or len(names) + len(encoder) != len(tree) or not names:
        raise ValueError(f"{net} layers must be hidden_0 .. hidden_N, got {sorted(tree)}")
    return [(tree[n]["kernel"], tree[n]["bias"]) for _, n in names]


def network_arrays(params: Mapping[str, Any], net: str, xp: Any) -> tuple[Any, Any, list[tuple[Any, Any]]]:
    """(mean, std, layers) of network `net` as `xp` arrays (the normaliser in float32): what `mlp`
    takes, for the same function on MJX (jax.numpy)."""
    mean, std = (xp.asarray(params["normalizer"][k], xp.float32) for k in ("mean", "std"))
    return mean, std, [(xp.asarray(k), xp.asarray(b)) for k, b in ordered_layers(params, net)]


def mlp(obs: Any, mean: Any, std: Any, layers: list[tuple[Any, Any]], xp: Any = np) -> Any:
    """The normalised observation through relu layers, the last one linear (numpy in float64, or
    jax.numpy for the composite's gate on MJX)."""
    h = ((np.asarray(obs, np.float64) if xp is np else obs) - mean) / std
    for kernel, bias in layers[:-1]:
        h = xp.maximum(h @ kernel + bias, 0.0)
    kernel, bias = layers[-1]
    return h @ kernel + bias


def deterministic_action(logits: Any, action_size: int, xp: Any = np) -> Any:
    """The deterministic action in [-1, 1] from the policy network's output: tanh(loc)."""
    return xp.tanh(logits[..., :action_size])


def encoder_layers(params: Mapping[str, Any], net: str, heightmap_shape: Any) -> list[tuple[Any, Any]]:
    """[(kernel, bias)] of conv_0..2 and encoder of network `net`: a terrain network's heightmap
    encoder, [] for a plain MLP."""
    tree = params[net]
    names = [n for n in _ENCODER if n in tree]
    if names and (len(names) != len(_ENCODER) or heightmap_shape is None):
        raise ValueError(f"a heightmap {net} network needs {', '.join(_ENCODER)} and the heightmap shape, got "
                         f"{sorted(tree)}")
    return [(tree[n]["kernel"], tree[n]["bias"]) for n in names]


def encode(z: np.ndarray, encoder: list[tuple[np.ndarray, np.ndarray]], heightmap_shape: tuple[int, int]) -> np.ndarray:
    """[state, heightmap] -> [state, encoding] of the normalised observation (the module docstring)."""
    rows, cols = heightmap_shape
    h = z[..., -rows * cols:].reshape(z.shape[:-1] + (rows, cols, 1))
    for (kernel, bias), stride in zip(encoder[:-1], HEIGHTMAP_STRIDES):
        h = np.maximum(conv_same(h, kernel, bias, stride), 0.0)
    kernel, bias = encoder[-1]
    h = np.maximum(h.reshape(h.shape[:-3] + (-1,)) @ kernel + bias, 0.0)
    return np.concatenate([z[..., : -rows * cols], h], axis=-1)


def forward(obs: Any, mean: np.ndarray, std: np.ndarray, encoder: list[tuple[np.ndarray, np.ndarray]],
            heightmap_shape: tuple[int, int] | None, layers: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """One network on raw observations: normalise, encode the heightmap where there is an encoder,
    then the MLP (float64)."""
    z = (np.asarray(obs, np.float64) - mean) / std
    return mlp(encode(z, encoder, heightmap_shape) if encoder else z, 0.0, 1.0, layers)


class NumpyValue:
    """The value network (Brax's PPO value MLP on the same normalised observation, one output;
    a terrain network encodes the heightmap first): the expected discounted return from a state,
    which a composite's gate compares."""

    def __init__(self, params: Mapping[str, Any], heightmap_shape: Any = None):
        self.mean = np.asarray(params["normalizer"]["mean"], np.float64)
        self.std = np.asarray(params["normalizer"]["std"], np.float64)
        self.layers = [(np.asarray(k, np.float64), np.asarray(b, np.float64))
                       for k, b in ordered_layers(params, "value")]
        self.encoder = [(np.asarray(k, np.float64), np.asarray(b, np.float64))
                        for k, b in encoder_layers(params, "value", heightmap_shape)]
        self.heightmap_shape = None if not self.encoder else (int(heightmap_shape[0]), int(heightmap_shape[1]))
        if self.layers[-1][1].shape != (1,):
            raise ValueError(f"the value network's last layer has {self.layers[-1][1].shape[0]} outputs, not 1")

    def __call__(self, obs: Any) -> np.ndarray:
        """V(obs); obs may be batched (..., observation_size)."""
        return forward(obs, self.mean, self.std, self.encoder, self.heightmap_shape, self.layers)[..., 0]


class NumpyPolicy:
    """Deterministic policy from `export_params`-style arrays: normaliser and MLP layers."""

    def __init__(self, mean: Any, std: Any, layers: list[tuple[Any, Any]], action_size: int | None = None,
                 encoder: list[tuple[Any, Any]] | None = None, heightmap_shape: Any = None):
        """`encoder`: the heightmap encoder's (kernel, bias) of conv_0..2 and encoder, with the
        heightmap's (rows, cols); none for a plain MLP."""
        self.encoder = [(np.asarray(k, np.float64), np.asarray(b, np.float64)) for k, b in encoder or []]
        self.heightmap_shape = None if not self.encoder else (int(heightmap_shape[0]), int(heightmap_shape[1]))
        if not layers:
            raise ValueError("the policy has no layers")
        self.mean = np.asarray(mean, np.float64)
        self.std = np.asarray(std, np.float64)
        self.layers = [(np.asarray(k, np.float64), np.asarray(b, np.float64)) for k, b in layers]
        out = self.layers[-1][1].shape[0]
        if out % 2:
            raise ValueError(f"the last layer has {out} outputs; expected 2 x action size (loc, scale)")
        self.action_size = out // 2 if action_size is None else int(action_size)
        if 2 * self.action_size != out:
            raise ValueError(f"the last layer has {out} outputs; expected 2 x {self.action_size}")
        first_in = self.layers[0][0].shape[0]
        if self.encoder:
            rows, cols = self.heightmap_shape
            first_in += rows * cols - self.encoder[-1][1].shape[0]
        if first_in != self.mean.shape[0] or self.std.shape != self.mean.shape:
            raise ValueError(f"normaliser size {self.mean.shape} does not match the first layer "
                             f"{self.layers[0][0].shape}")
        for (k0, _), (k1, _) in zip(self.layers, self.layers[1:]):
            if k0.shape[1] != k1.shape[0]:
                raise ValueError(f"layer sizes do not chain: {k0.shape} then {k1.shape}")

    @classmethod
    def from_params(cls, params: Mapping[str, Any], heightmap_shape: Any = None) -> NumpyPolicy:
        """From {"normalizer": {"mean", "std"}, "policy": {"hidden_0": {"kernel", "bias"}, ...}}
        (and conv_0..2, encoder for a heightmap policy, whose heightmap is rows x cols)."""
        return cls(params["normalizer"]["mean"], params["normalizer"]["std"], ordered_layers(params, "policy"),
                   encoder=encoder_layers(params, "policy", heightmap_shape), heightmap_shape=heightmap_shape)

    @property
    def observation_size(self) -> int:
        return int(self.mean.shape[0])

    @property
    def hidden_sizes(self) -> tuple[int, ...]:
        return tuple(int(b.shape[0]) for _, b in self.layers[:-1])

    def logits(self, obs: Any) -> np.ndarray:
        """The network output (..., 2 * action_size): loc, then the pre-softplus scale."""
        return forward(obs, self.mean, self.std, self.encoder, self.heightmap_shape, self.layers)

    def __call__(self, obs: Any) -> np.ndarray:
        """Deterministic action(s) in [-1, 1]; obs may be batched (..., observation_size)."""
        return deterministic_action(self.logits(obs), self.action_size)
