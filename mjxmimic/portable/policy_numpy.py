"""The trained policy's forward pass in numpy: no JAX, so an exported policy runs anywhere.

It is the function Brax's PPO networks compute (mjxmimic.learn.ppo, "Exported parameters"), written out:

    z   = (obs - mean) / std                        Brax running_statistics.normalize, no clipping
    h   = relu(z @ kernel_i + bias_i)               every hidden layer (Brax MLP "hidden_i")
    out = h @ kernel_L + bias_L                     the last layer, 2 * action_size numbers
    loc = out[:action_size]
    action = tanh(loc)                              NormalTanhDistribution.mode: the deterministic
                                                    (evaluation / playback) action, in [-1, 1]

The computation runs in float64 (the parameters are float32 as trained); the test suite checks
it against the JAX policy to 1e-5.

The value network (Brax's `make_value_network`, exported beside the policy for composites) is the
same MLP on the same normalised observation, with one output: V(obs) = (h @ kernel_L + bias_L)[0].
`mlp` is written over an array module `xp` so that MJX evaluation runs the identical function.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import numpy as np

_LAYER = re.compile(r"hidden_(\d+)$")


def mlp(layers: list[tuple[Any, Any]], mean: Any, std: Any, obs: Any, xp: Any = np) -> Any:
    """The normalised observation through relu layers, the last one linear."""
    h = (obs - mean) / std
    for kernel, bias in layers[:-1]:
        h = xp.maximum(h @ kernel + bias, 0.0)
    kernel, bias = layers[-1]
    return h @ kernel + bias


def ordered_layers(net: Mapping[str, Any]) -> list[tuple[Any, Any]]:
    """{"hidden_0": {"kernel", "bias"}, ...} -> [(kernel, bias), ...] in layer order."""
    names = sorted((int(_LAYER.match(n).group(1)), n) for n in net if _LAYER.match(n))
    if [i for i, _ in names] != list(range(len(names))) or len(names) != len(net):
        raise ValueError(f"network layers must be hidden_0 .. hidden_N, got {sorted(net)}")
    return [(net[n]["kernel"], net[n]["bias"]) for _, n in names]


class NumpyPolicy:
    """Deterministic policy from `export_params`-style arrays: normaliser and MLP layers."""

    def __init__(self, mean: Any, std: Any, layers: list[tuple[Any, Any]], action_size: int | None = None):
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
        if self.layers[0][0].shape[0] != self.mean.shape[0] or self.std.shape != self.mean.shape:
            raise ValueError(f"normaliser size {self.mean.shape} does not match the first layer "
                             f"{self.layers[0][0].shape}")
        for (k0, _), (k1, _) in zip(self.layers, self.layers[1:]):
            if k0.shape[1] != k1.shape[0]:
                raise ValueError(f"layer sizes do not chain: {k0.shape} then {k1.shape}")

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> NumpyPolicy:
        """From {"normalizer": {"mean", "std"}, "policy": {"hidden_0": {"kernel", "bias"}, ...}}."""
        layers = ordered_layers(params["policy"])
        return cls(params["normalizer"]["mean"], params["normalizer"]["std"], layers)

    @property
    def observation_size(self) -> int:
        return int(self.mean.shape[0])

    @property
    def hidden_sizes(self) -> tuple[int, ...]:
        return tuple(int(b.shape[0]) for _, b in self.layers[:-1])

    def logits(self, obs: Any) -> np.ndarray:
        """The network output (..., 2 * action_size): loc, then the pre-softplus scale."""
        return mlp(self.layers, self.mean, self.std, np.asarray(obs, np.float64))

    def __call__(self, obs: Any) -> np.ndarray:
        """Deterministic action(s) in [-1, 1]; obs may be batched (..., observation_size)."""
        return np.tanh(self.logits(obs)[..., : self.action_size])


class NumpyValue:
    """The state-value estimate V(obs) from the exported value network (shares the policy's
    normaliser): {"normalizer": {"mean", "std"}, "value": {"hidden_0": ..., "hidden_L": (h, 1)}}."""

    def __init__(self, mean: Any, std: Any, layers: list[tuple[Any, Any]]):
        self.mean = np.asarray(mean, np.float64)
        self.std = np.asarray(std, np.float64)
        self.layers = [(np.asarray(k, np.float64), np.asarray(b, np.float64)) for k, b in layers]
        if not self.layers or self.layers[-1][1].shape != (1,):
            raise ValueError("the value network's last layer must have one output")
        if self.layers[0][0].shape[0] != self.mean.shape[0]:
            raise ValueError(f"normaliser size {self.mean.shape} does not match the value network's first "
                             f"layer {self.layers[0][0].shape}")

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> NumpyValue:
        return cls(params["normalizer"]["mean"], params["normalizer"]["std"], ordered_layers(params["value"]))

    @property
    def hidden_sizes(self) -> tuple[int, ...]:
        return tuple(int(b.shape[0]) for _, b in self.layers[:-1])

    def __call__(self, obs: Any) -> Any:
        """V(obs): a float for one observation, (...,) for a batch."""
        return mlp(self.layers, self.mean, self.std, np.asarray(obs, np.float64))[..., 0]
