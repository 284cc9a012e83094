"""`mjxmimic train`: PPO on one clip; a run folder with config, metrics, checkpoints and eval.

    mjxmimic train [--clip NAME|PATH] [--preset cpu|gpu] [--set section.key=value ...]
                   [--out DIR] [--seed N] [--name NAME] [--init-from POLICY|RUN]
    mjxmimic train --resume DIR [--set run.key=value ...] [--set ppo.learning_rate*=X]

The run folder (mjxmimic.runs.folder's layout) is runs/<clip>-<timestamp>/ by default,
runs/<NAME>/ with --name, exactly DIR with --out. Training is mjxmimic.runs.train_loop's: a
checkpoint every run.checkpoint_every samples, at the end, at run.max_seconds (continue with
--resume) and on Ctrl-C (then exit 130); eval.json at the end. This module parses and prints.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from mjxmimic.commands import arg_types
from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.runs import folder


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--clip", help="clip NAME or PATH (default: the config's clip)")
    parser.add_argument("--character", metavar="NAME|PATH",
                        help="the simulated character (character.xml): humanoid (default), dog3d, g1, or an MJCF file")
    parser.add_argument("--task", choices=config_lib.TASKS,
                        help="a task to chase while imitating (task.name): heading = walk in a commanded "
                             "direction at a commanded speed; strike = hit a target (the spinkick); "
                             "throw = throw a ball onto a target on the floor (the pitch clip)")
    parser.add_argument("--terrain", choices=config_lib.TERRAINS,
                        help="a course to cross (terrain.kind; mjxmimic.core.terrain), seen through a heightmap; "
                             "--set terrain.seed=N, terrain.difficulty=0..1")
    parser.add_argument("--preset", default=None, choices=sorted(config_lib.PRESETS),
                        help="config preset (default: gpu where JAX sees a GPU, else cpu)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a config value (repeatable), e.g. --set ppo.learning_rate=3e-4")
    parser.add_argument("--out", type=arg_types.path, help="run folder (exactly this path)")
    parser.add_argument("--name", help="run name: the folder runs/NAME")
    parser.add_argument("--seed", type=arg_types.seed, help="PRNG seed (run.seed)")
    parser.add_argument("--resume", type=arg_types.path, metavar="DIR", help="continue the run in DIR from its latest checkpoint")
    parser.add_argument("--init-from", metavar="POLICY|RUN",
                        help="start a new run from the networks and observation normaliser of a policy file or a "
                             "run folder (its policy.npz, else its best checkpoint; run.init_from), e.g. to go on "
                             "training a learnt skill with pushes; the optimiser and the schedule start afresh, so set "
                             "ppo.learning_rate well below the gpu preset's 3e-4 start (it ends at 3e-5); "
                             "run.best_from_samples keeps the best from later on")
    parser.add_argument("--wandb", metavar="PROJECT", default=None,
                        help="also log to this Weights & Biases project (run.wandb_project; the wandb extra; "
                             "WANDB_MODE=offline without network)")


def default_preset() -> str:
    """The preset for a run that names none: `gpu` where JAX's default device is a GPU, else
    `cpu` (the 8192-env preset would crawl on a CPU); says which on stderr."""
    import jax

    preset = "gpu" if jax.default_backend() == "gpu" else "cpu"
    found = "a GPU" if preset == "gpu" else "no GPU"
    print(f"mjxmimic train: no --preset given: using '{preset}' ({found} found; --preset cpu|gpu to choose)",
          file=sys.stderr)
    return preset


def resolve_run(args: argparse.Namespace) -> tuple[config_lib.Config, Path, bool]:
    """(config, run folder, resuming) from the command line; nothing is written."""
    overrides = config_lib.parse_set_args(args.overrides or [])
    if getattr(args, "wandb", None):
        overrides["run.wandb_project"] = args.wandb
    if args.resume is not None:
        for flag in ("clip", "character", "terrain", "preset", "out", "name", "init_from"):
            if getattr(args, flag, None) is not None:
                raise UserError(f"--{flag.replace('_', '-')} cannot be combined with --resume "
                                f"(the run's config.json decides)")
        run_dir = folder.require(args.resume)
        # The learning rate and its schedule may change (say, a fine-tuning phase): Adam's state
        # does not depend on them.
        bad = [k for k in overrides if not k.startswith(("run.", "ppo.learning_rate"))]
        if bad:
            raise UserError(f"--set {bad[0]}: only run.* and ppo.learning_rate* keys may change on --resume")
        config = folder.load_config(run_dir)  # a run with no checkpoint yet starts over from it
        if args.seed is not None:
            raise UserError("--seed cannot be combined with --resume (the checkpoint holds the PRNG state)")
        config = config_lib.apply_overrides(config, overrides)
        return config, run_dir, True

    if args.clip is not None:
        overrides["clip.name"] = args.clip
    if args.task is not None:
        overrides["task.name"] = args.task
    if args.terrain is not None:
        overrides["terrain.kind"] = args.terrain
    if args.character is not None:
        overrides["character.xml"] = args.character
    if args.seed is not None:
        overrides["run.seed"] = str(args.seed)
    if getattr(args, "init_from", None) is not None:
        overrides["run.init_from"] = args.init_from
    config = config_lib.make_config(args.preset or default_preset(), overrides)
    if args.out is not None:
        run_dir = args.out
    elif args.name is not None:
        run_dir = Path("runs") / args.name
    else:
        from mjxmimic.motion.clip import clip_label

        run_dir = Path("runs") / f"{clip_label(config.clip.name)}-{time.strftime('%Y%m%d-%H%M%S')}"
    folder.refuse_non_folder(run_dir)  # before the env is built
    if folder.holds_run(run_dir):
        raise UserError(f"{run_dir}: already holds a run (continue it with --resume {run_dir})")
    return config, run_dir, False


def in_words(result: dict, config: config_lib.Config) -> str:
    """An evaluation for a newcomer: what NR means, how often the character fell, how long it lasted."""
    horizon = result.get("mean_horizon_steps", 0) / config.env.control_hz
    return (f"NR {result['nr']:.3f} (0 = falls at once, 1 = tracks the clip perfectly); "
            f"fell in {result['fall_rate']:.0%} of {result.get('episodes', '?')} evaluation episodes, "
            f"lasting {result['survival_s']:.2f} s of {horizon:.2f} s on average")


def run(args: argparse.Namespace) -> int:
    from mjxmimic.runs.train_loop import train

    start = time.time()
    config, run_dir, resume = resolve_run(args)
    if config.run.wandb_project:
        from mjxmimic.runs.wandb_log import check_available

        check_available()
    say = lambda text: print(f"mjxmimic train: {text}", file=sys.stderr, flush=True)  # noqa: E731
    import jax

    env = init_policy = None
    if not resume:
        # Read the character and the clips before anything is said or written: a bad clip is
        # then the only line, and leaves no folder.
        from mjxmimic.envs.mjx_env import ImitationEnv, load_env_inputs

        inputs = load_env_inputs(config)
        if config.run.init_from:
            from mjxmimic.runs.warm_start import read_start

            init_policy = read_start(config, inputs[0], [c.name for c in inputs[1]])
            training = init_policy.manifest.get("training", {})
            nr = training.get("eval", {}).get("nr")
            say(f"starting from {config.run.init_from} (trained {training.get('samples', 0):,} samples"
                + (f", NR {nr:.3f})" if nr is not None else ")"))
    cache = jax.config.jax_compilation_cache_dir
    say(f"building the env ({config.clip.name}, {config.ppo.num_envs:,} envs); the first iteration "
        f"then waits for JAX to compile the train step" + (f" (or to load it from {cache})" if cache else ""))
    if not resume:
        env = ImitationEnv(config, *inputs)
        say(f"env built in {time.time() - start:.0f} s (physics: {env.backend}); compiling")
    outcome = train(config, run_dir, resume=resume, env=env, start_time=start, init_policy=init_policy,
                    progress=True if sys.stderr.isatty() else "plain")
    s = outcome.summary
    line = (f"{run_dir}: {outcome.reason} after {s['samples']:,} samples, {s['iterations']} iterations, "
            f"{s['train_seconds']:.0f} s")
    if "samples_per_s_steady" in s:
        line += f", {s['samples_per_s_steady']:,.0f} samples/s steady"
    final = outcome.final_eval
    if final is not None:
        line += "; " + in_words(final, config)
    elif outcome.reason == "max_seconds" and outcome.call_iterations == 0:  # the resume keeps the bound
        line += (f"; run.max_seconds ({config.run.max_seconds:g} s) ran out before the first iteration: "
                 f"continue with: mjxmimic train --resume {run_dir} --set run.max_seconds=0 (no limit)")
    elif outcome.reason == "max_seconds":
        line += f"; continue with: mjxmimic train --resume {run_dir}"
    print(line)
    return outcome.exit_code
