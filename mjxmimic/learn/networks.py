"""The policy and value networks: Brax's PPO MLPs, or with terrain the heightmap encoder of
DeepMimic's terrain policies (DEEPMIMIC.md: "3 conv layers ... then a 64-unit layer, joined with
the state"); their initial output layer; the policy function of exported parameters.

Initial action std. Brax's `NormalTanhDistribution` splits the policy output into (loc, s) and
uses std = softplus(s) + ppo.min_action_std (pre-tanh). After the usual init, the last policy
layer is changed (`init_output_layer`): kernel columns of the std half are set to 0 and their
bias to softplus^-1(ppo.init_action_std - ppo.min_action_std), so every state starts with exactly
that std; kernel columns of the mean half are scaled by 0.01 (initial actions near 0, as in
DeepMimic's 0.01 output init). With ppo.std_mode=learned both halves train (the std can become
state dependent); with fixed the std half never changes.

The observation of a terrain env ends with the heightmap (mjxmimic.envs.step: rows x cols heights
in the heading frame). `HeightmapMLP` splits it off, runs it through CONV_LAYERS (`PatchConv`:
SAME padding, relu), flattens, a dense `encoder` layer of ENCODER_UNITS (relu), concatenates that
with the state features (everything before the heightmap, normalised) and runs the usual MLP
(`hidden_0` .. `hidden_L`, relu after all but the last). Layer names are flat (conv_0, conv_1,
conv_2, encoder, hidden_i), so the portable policy file stores them as it stores an MLP's, and
mjxmimic.portable.policy_numpy computes the same function without JAX.

The paper's first two layers are 16 8x8 and 32 4x4 filters on a heightmap of unknown size; the
strides and sizes below keep a 2 x 2 x 32 map before the dense layer on the 8 x 8 default grid
(4 x 4 x 32 on a 16 x 16 one); 8x8 filters would cover the whole default grid.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from brax.training import networks as brax_networks
from brax.training.acme import running_statistics
from brax.training.agents.ppo import networks as ppo_networks
from brax.training.distribution import NormalTanhDistribution
from flax import linen

from mjxmimic.core.config import Config

# (filters, kernel size, stride) of each conv layer; mirrored by policy_numpy.HEIGHTMAP_CONV
CONV_LAYERS = ((16, 4, 2), (32, 3, 2), (32, 3, 1))
ENCODER_UNITS = 64


class PatchConv(linen.Module):
    """`linen.Conv` with SAME padding, its parameters and its function, computed as one matrix
    product over the input's patches (k x k strided slices, concatenated): on the heightmap's tiny
    maps the training loop needs about half the GPU memory of XLA's convolutions, at the same
    speed (experiments/terrain/README.md), and trained policies and their exports are unchanged."""

    features: int
    kernel_size: int
    stride: int

    @linen.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        k, s, cin = self.kernel_size, self.stride, x.shape[-1]
        kernel = self.param("kernel", linen.initializers.lecun_normal(), (k, k, cin, self.features))
        bias = self.param("bias", linen.initializers.zeros_init(), (self.features,))
        (h0, h1), (w0, w1) = jax.lax.padtype_to_pads(x.shape[-3:-1], (k, k), (s, s), "SAME")
        x = jnp.pad(x, [(0, 0)] * (x.ndim - 3) + [(h0, h1), (w0, w1), (0, 0)])
        rows, cols = (x.shape[-3] - k) // s + 1, (x.shape[-2] - k) // s + 1
        patches = jnp.concatenate([x[..., i:i + s * (rows - 1) + 1:s, j:j + s * (cols - 1) + 1:s, :]
                                   for i in range(k) for j in range(k)], axis=-1)  # (i, j, channel)
        return patches @ kernel.reshape(k * k * cin, self.features) + bias


class HeightmapMLP(linen.Module):
    """The encoder + MLP above; `heightmap_shape` (rows, cols) are the observation's last numbers."""

    layer_sizes: Sequence[int]
    heightmap_shape: tuple[int, int]

    @linen.compact
    def __call__(self, obs: jax.Array) -> jax.Array:
        rows, cols = self.heightmap_shape
        state, hmap = obs[..., : -rows * cols], obs[..., -rows * cols:]
        h = hmap.reshape(hmap.shape[:-1] + (rows, cols, 1))
        for i, (filters, size, stride) in enumerate(CONV_LAYERS):
            h = linen.relu(PatchConv(filters, size, stride, name=f"conv_{i}")(h))
        h = linen.relu(linen.Dense(ENCODER_UNITS, name="encoder")(h.reshape(h.shape[:-3] + (-1,))))
        h = jnp.concatenate([state, h], axis=-1)
        for i, size in enumerate(self.layer_sizes):
            h = linen.Dense(size, kernel_init=jax.nn.initializers.lecun_uniform(), name=f"hidden_{i}")(h)
            if i < len(self.layer_sizes) - 1:
                h = linen.relu(h)
        return h


def _network(module: linen.Module, observation_size: int, preprocess: Any,
             squeeze: bool = False) -> brax_networks.FeedForwardNetwork:
    def init(key: jax.Array) -> Any:
        return module.init(key, jnp.zeros((1, observation_size)))

    def apply(processor_params: Any, params: Any, obs: jax.Array) -> jax.Array:
        out = module.apply(params, preprocess(obs, processor_params))
        return jnp.squeeze(out, axis=-1) if squeeze else out

    return brax_networks.FeedForwardNetwork(init=init, apply=apply)


def make_heightmap_networks(observation_size: int, action_size: int, policy_hidden: Sequence[int],
                            value_hidden: Sequence[int], heightmap_shape: Sequence[int],
                            preprocess: Any, min_std: float) -> ppo_networks.PPONetworks:
    """Brax PPO networks (tanh-normal policy, scalar value) whose policy and value both read the
    heightmap through their own encoder."""
    dist = NormalTanhDistribution(event_size=action_size, min_std=min_std)
    shape = (int(heightmap_shape[0]), int(heightmap_shape[1]))
    policy = HeightmapMLP(layer_sizes=(*policy_hidden, dist.param_size), heightmap_shape=shape)
    value = HeightmapMLP(layer_sizes=(*value_hidden, 1), heightmap_shape=shape)
    return ppo_networks.PPONetworks(policy_network=_network(policy, observation_size, preprocess),
                                    value_network=_network(value, observation_size, preprocess, squeeze=True),
                                    parametric_action_distribution=dist)


def make_networks(observation_size: int, action_size: int, config: Config) -> ppo_networks.PPONetworks:
    """The run's networks: Brax's MLPs (relu), or the heightmap encoder's with terrain; the
    tanh-normal policy's std floored at ppo.min_action_std."""
    if config.terrain.kind != "none":
        return make_heightmap_networks(observation_size, action_size, config.ppo.policy_hidden,
                                       config.ppo.value_hidden, config.terrain.heightmap_shape,
                                       running_statistics.normalize, config.ppo.min_action_std)
    networks = ppo_networks.make_ppo_networks(
        observation_size, action_size,
        preprocess_observations_fn=running_statistics.normalize,
        policy_hidden_layer_sizes=tuple(config.ppo.policy_hidden),
        value_hidden_layer_sizes=tuple(config.ppo.value_hidden),
        activation=linen.relu,
        distribution_type="tanh_normal",
    )
    return networks.replace(parametric_action_distribution=NormalTanhDistribution(
        event_size=action_size, min_std=config.ppo.min_action_std))


def last_layer(layers: dict) -> str:
    """The output layer's name: the last hidden_i (a heightmap policy also has conv and encoder layers)."""
    return f"hidden_{sum(name.startswith('hidden_') for name in layers) - 1}"


def init_output_layer(policy_params: dict, action_size: int, init_std: float, min_std: float) -> dict:
    """Set the initial std exactly and shrink the initial mean (see the module docstring)."""
    layers = policy_params["params"]
    last = last_layer(layers)
    kernel, bias = layers[last]["kernel"], layers[last]["bias"]
    kernel = jnp.concatenate([kernel[:, :action_size] * 0.01, jnp.zeros_like(kernel[:, action_size:])], axis=1)
    std_bias = float(np.log(np.expm1(init_std - min_std)))  # softplus^-1
    bias = jnp.concatenate([jnp.zeros_like(bias[:action_size]), jnp.full_like(bias[action_size:], std_bias)])
    return {**policy_params, "params": {**layers, last: {"kernel": kernel, "bias": bias}}}


def make_policy_fn(networks: ppo_networks.PPONetworks, params: dict, deterministic: bool = True) -> Callable:
    """fn(obs, key) -> action for `mjxmimic.learn.ppo.export_params`-style params. Deterministic: tanh(loc)."""
    normalizer = running_statistics.NestedMeanStd(mean=params["normalizer"]["mean"],
                                                  std=params["normalizer"]["std"])
    policy_params = {"params": params["policy"]}
    dist = networks.parametric_action_distribution

    def policy(obs: jax.Array, key: jax.Array) -> jax.Array:
        logits = networks.policy_network.apply(normalizer, policy_params, obs)
        if deterministic:
            return dist.mode(logits)
        return dist.sample(logits, key)

    return policy
