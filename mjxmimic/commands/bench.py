"""`mjxmimic bench`: the standard throughput set (physics only, env step, full training loop)
across env counts at one preset's physics settings; prints a table and writes JSON."""

from __future__ import annotations

import argparse
import json

from mjxmimic.commands import arg_types
from mjxmimic.core import config as config_lib


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--preset", default="gpu", choices=sorted(config_lib.PRESETS),
                        help="config preset to measure (default: gpu)")
    parser.add_argument("--clip", default=None, help="clip NAME or PATH (default: the preset's clip)")
    parser.add_argument("--character", default=None, metavar="NAME|PATH",
                        help="the simulated character: humanoid (default), dog3d, g1, or an MJCF file")
    parser.add_argument("--terrain", default=None, choices=config_lib.TERRAINS,
                        help="bench on a terrain course (terrain.kind) instead of the flat floor")
    parser.add_argument("--num-envs", type=int, nargs="+", default=None,
                        help="env counts (default: 4096 8192 16384 65536 for gpu, 32 128 for cpu)")
    parser.add_argument("--kinds", nargs="+", default=["physics_only", "env_step", "train_loop"],
                        choices=["physics_only", "env_step", "train_loop"],
                        help="what to measure: physics alone, the env step, the full training loop (default: all)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a config key (repeatable)")
    parser.add_argument("--out", type=arg_types.path, default=None, help="write the results as JSON here")


def run(args: argparse.Namespace) -> int:
    import dataclasses

    from mjxmimic.ops import bench
    from mjxmimic.envs.mjx_env import ImitationEnv, load_env_inputs

    overrides = config_lib.parse_set_args(args.overrides)
    if args.clip:
        overrides["clip.name"] = args.clip
    if args.character:
        overrides["character.xml"] = args.character
    if args.terrain is not None:
        overrides["terrain.kind"] = args.terrain
    base = config_lib.make_config(args.preset, overrides)
    counts = args.num_envs or ([4096, 8192, 16384, 65536] if args.preset == "gpu" else [32, 128])
    character, clips, weights = load_env_inputs(base)
    rows = []
    for n in counts:
        cfg = config_lib.apply_overrides(base, {"ppo.num_envs": n})
        env = ImitationEnv(cfg, character, clips, weights)
        for kind in args.kinds:
            m = bench.train_loop(env, cfg) if kind == "train_loop" else getattr(bench, kind)(env, n)
            rows.append(dataclasses.asdict(m))
            print(json.dumps(rows[-1]), flush=True)
            if args.out:
                args.out.parent.mkdir(parents=True, exist_ok=True)
                args.out.write_text(json.dumps({"info": bench.environment_info(), "preset": args.preset,
                                                "overrides": overrides, "rows": rows}, indent=1))
    print(f"{'kind':13} {'physics':>7} {'envs':>6} {'hz':>4} {'solver':>6} {'samples/s':>11} {'compile s':>9} {'peak MiB':>9}")
    for r in rows:
        mem = f"{r['peak_memory_bytes'] / 2**20:9.0f}" if r["peak_memory_bytes"] else f"{'-':>9}"
        print(f"{r['kind']:13} {r.get('backend', 'jax'):>7} {r['num_envs']:>6} {r['physics_hz']:>4} {bench.solver_label(r):>6} "
              f"{r['samples_per_s']:>11,.0f} {r['compile_s']:>9.1f} {mem}")
    return 0
