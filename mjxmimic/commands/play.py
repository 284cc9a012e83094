"""`mjxmimic play POLICY`: an exported policy on MuJoCo's CPU simulator, numpy only (no JAX).

    mjxmimic play POLICY [--clip NAME|PATH] [--episodes N] [--seed S | --grid SECONDS] [--json] [--viewer]

POLICY is a file from `mjxmimic export` (.npz, or .onnx with the onnx package) or a run folder
holding policy.npz. Runs the sim-to-sim NR protocol of EVALUATION.md (mjxmimic.portable.playback): N
episodes (default 16) with the deterministic policy, each from the reference state at its start
time, with the training's control step (PD substepping, fall rules) on mujoco.mj_step, its
contact solve run to convergence (--solver-iterations N limits it; core.config.playback_config).
Start times are the MJX evaluation's own (carried in the file) unless --seed, --clip or more episodes
than it ran ask for a fresh seeded draw, or --grid for one every SECONDS over the clip (the NR
apart from the draw). Reports NR, fall rate, the runs of start times that fell, survival, pose and
end-effector errors, and the ratio CPU NR / MJX NR (the training-side NR recorded at export).
--viewer shows the episodes in MuJoCo's viewer, in real time, where a display exists.
--skill-sequence and --switch-trials play a dataset policy's skill selector (mjxmimic.portable.skills);
--switch-routes TRIALS.json sends the switches that those trials saw fall through a third skill.
--push runs DeepMimic's Table 6 push test instead (mjxmimic.portable.push_playback), as
`mjxmimic eval RUN --push` does on MJX.
A composite file (`mjxmimic compose`) plays one run of --seconds (optionally pushed with
--push-once FORCE@TIME) and reports which expert ran when; with --knockdowns N it measures the
recovery rate (mjxmimic.task.recovery) on the CPU instead, and with --episodes N each clip's NR
with its own expert and under the gate (mjxmimic.portable.composite.clip_nr).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

from mjxmimic.commands import arg_types, character_option
from mjxmimic.commands.evaluate import fall_windows_text
from mjxmimic.runs import folder

DEFAULT_EPISODES = 16


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("policy", type=arg_types.path, metavar="POLICY", help="exported policy file or run folder")
    parser.add_argument("--clip", metavar="NAME|PATH", help="play on another clip (default: the file's own)")
    character_option.add_option(parser)
    parser.add_argument("--clips-dir", metavar="DIR", default=None, help="extra folder for clip names")
    parser.add_argument("--episodes", type=int, default=None, help=f"episodes (default {DEFAULT_EPISODES})")
    parser.add_argument("--seed", type=arg_types.seed, default=None,
                        help="draw start times from this seed instead of using the MJX evaluation's")
    parser.add_argument("--grid", type=arg_types.at_least(1e-3, float), default=None, metavar="SECONDS",
                        help="start times every SECONDS over the clip instead of a random draw: the NR over "
                             "the whole clip, apart from the draw, and where in it the policy falls")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--viewer", action="store_true", help="watch in MuJoCo's viewer (needs a display)")
    parser.add_argument("--solver-iterations", type=int, default=None, metavar="N",
                        help="MuJoCo's Newton and line-search iteration limits (default: its own, 100 and 50, "
                             "or the training's if higher: a converged solve, as MJX-Warp's is at the "
                             "training's 4; mjxmimic.core.config.playback_config)")
    parser.add_argument("--push", action="store_true",
                        help="the push test instead of NR: the largest 0.2 s pelvis push, forward and "
                             "sideways, that 90%% of the trials survive (EVALUATION.md)")
    parser.add_argument("--trials", type=int, default=32, help="trials per force of the push test (default 32)")
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help="processes that run the push test's trials (default: one per CPU core)")
    parser.add_argument("--skill-sequence", metavar="SKILL:SECONDS,...", default=None,
                        help="a policy trained on a dataset with the skill observation: switch the skill it "
                             "follows, e.g. \"walk:4,run:4,walk:4\" (one run, no reset between skills)")
    parser.add_argument("--switch-trials", type=int, default=None, metavar="N",
                        help="a policy trained on a dataset with the skill observation: how often its switches "
                             "hold (up 4 s after), over N switch moments for every ordered pair of skills")
    parser.add_argument("--switch-lead", type=float, default=1.0, metavar="SECONDS",
                        help="with --switch-trials: seconds of the first skill before the first switch moment "
                             "(default 1; the moments then come every 4 control steps)")
    parser.add_argument("--switch-entry", choices=["phase", "nearest"], default=None,
                        help="where a switch between cyclic clips enters the next: the same phase or the "
                             "nearest reference pose (default: the rule the policy was trained with)")
    parser.add_argument("--switch-routes", type=arg_types.path, default=None, metavar="TRIALS.json",
                        help="route switches that the trials (the JSON of --switch-trials N --json) saw "
                             "fall through a third skill, for 1 s, where that held more often")
    parser.add_argument("--finish-cycle", metavar="SKILL[,SKILL]|auto|none", default=None,
                        help="switches out of these skills wait for the end of their cycle, so that a backflip "
                             "lands before the next skill starts (default auto: the cyclic skills whose clip "
                             "lifts both feet 0.2 m off the ground; none: every switch at once)")
    composite = parser.add_argument_group("composite files (mjxmimic compose)")
    composite.add_argument("--seconds", type=float, default=None, help="length of the run (default 10)")
    composite.add_argument("--start", type=float, default=None, help="clip time of the start expert to start at "
                           "(default 0)")
    composite.add_argument("--expert", metavar="NAME", default=None,
                           help="the expert to start in (default: the first looping one)")
    composite.add_argument("--temperature", type=float, default=None, help="override the file's gate temperature")
    composite.add_argument("--push-once", metavar="FORCE@TIME", default=None,
                           help="push the pelvis with FORCE newtons for 0.2 s at TIME seconds")
    composite.add_argument("--push-direction", choices=["forward", "sideways", "backward", "random"],
                           default=None, help="of --push-once (default forward) or of the knock-downs (default random)")
    composite.add_argument("--knockdowns", type=int, default=None,
                           help="the recovery rate over this many knock-downs instead (mjxmimic.task.recovery)")
    composite.add_argument("--force", type=float, default=None,
                           help="the knock-down push in newtons (default mjxmimic.task.recovery.DEFAULT_FORCE_N)")
    composite.add_argument("--save-states", type=arg_types.path, default=None, metavar="FILE.npz",
                           help="with --knockdowns: also write the knocked-down bodies' states (qpos, qvel), "
                                "for getups to train from (env.start_states)")


def _start_times(env, manifest: dict, episodes: int | None, seed: int | None, clip_overridden: bool,
                 grid: float | None = None):
    """(start times, label): a grid if asked for, the MJX evaluation's where they apply, else a
    seeded draw."""
    if grid is not None:
        return _grid(env, grid)
    ev = manifest.get("training", {}).get("eval") or {}
    stored = ev.get("start_times") or []
    n = DEFAULT_EPISODES if episodes is None else episodes
    if seed is None and not clip_overridden and stored and n <= len(stored):
        return stored[:n], f"the MJX evaluation's (seed {ev.get('seed')}, first {n} of {len(stored)})"
    seed = 0 if seed is None else seed
    return env.start_times(n, seed).tolist(), f"seeded draw (numpy, seed {seed})"


def _grid(env, step: float, clip: int = 0) -> tuple[list[float], str]:
    """(start times, label): one every `step` seconds over the interval the evaluation draws from."""
    from mjxmimic.task.nr import grid_starts

    return grid_starts(env.eval_start_limits[clip], step).tolist(), f"a grid over the clip, every {step:g} s"


class _RealTime:
    """Holds a viewer loop to the control rate; after a slow step it goes on from now, not racing."""

    def __init__(self, dt: float):
        self.dt, self.t = dt, time.perf_counter()

    def wait(self) -> None:
        self.t += self.dt
        ahead = self.t - time.perf_counter()
        if ahead > 0:
            time.sleep(ahead)
        else:
            self.t = time.perf_counter()


def _viewer_loop(env, policy, starts):
    import mujoco.viewer

    from mjxmimic.portable.playback import evaluate
    from mjxmimic.portable.render import decorate, goal_arrow, goal_markers

    with mujoco.viewer.launch_passive(env.model, env.data) as viewer:
        clock = _RealTime(env.control_dt)

        def on_step(e, s):
            if e.config.task.name:  # the goal (the thrown ball is in the viewer's model)
                viewer.user_scn.ngeom = 0
                decorate(viewer.user_scn, [goal_arrow(e)], goal_markers(e, ball=False))
            viewer.sync()
            clock.wait()
            return viewer.is_running()

        return evaluate(env, policy, starts, on_step=on_step)


def _play_clips(args: argparse.Namespace, pf, env, only: int | None) -> int:
    """A dataset policy: each clip (or the one asked for) from the MJX evaluation's start times of
    that clip, each with its own skill one-hot."""
    from mjxmimic.portable.playback import evaluate

    ev = (pf.manifest.get("training", {}).get("eval") or {}).get("clips") or {}
    n = DEFAULT_EPISODES if args.episodes is None else args.episodes
    policy = pf.policy()
    rows = {}
    for index, clip in enumerate(env.clips):
        if only is not None and index != only:
            continue
        stored = (ev.get(clip.name) or {}).get("start_times") or []
        if args.grid is not None:
            starts, label = _grid(env, args.grid, index)
        elif args.seed is None and n <= len(stored):
            starts, label = stored[:n], f"the MJX evaluation's (first {n} of {len(stored)})"
        else:
            seed = 0 if args.seed is None else args.seed
            starts, label = env.start_times(n, seed, index).tolist(), f"seeded draw (numpy, seed {seed})"
        result = evaluate(env, policy, starts, clip=index)
        mjx_nr = (ev.get(clip.name) or {}).get("nr")
        rows[clip.name] = {"nr": result["nr"], "nr_paper": result["nr_paper"],
                           "nr_paper_discounted": result["nr_paper_discounted"], "fall_rate": result["fall_rate"],
                           "survival_s": result["survival_s"], "episodes": result["episodes"], "starts": label,
                           "fall_windows": result["fall_windows"],
                           "mjx_nr": mjx_nr, "ratio": result["nr"] / mjx_nr if mjx_nr else None}
    if args.json:
        print(json.dumps({"policy": str(pf.path), "simulator": env.physics.simulator, "clips": rows}))
        return 0
    print(f"{pf.path}: {len(env.clips)} skills, {env.physics.simulator}")
    print(f"  {'skill':<20} {'NR (CPU)':>9} {'paper form':>10} {'MJX NR':>7} {'ratio':>6} {'falls':>6}")
    for name, r in rows.items():
        mjx = "-" if r["mjx_nr"] is None else f"{r['mjx_nr']:.3f}"
        ratio = "-" if r["ratio"] is None else f"{r['ratio']:.3f}"
        print(f"  {name:<20} {r['nr']:>9.3f} {r['nr_paper']:>10.3f} {mjx:>7} {ratio:>6} {r['fall_rate']:>6.2f}")
    return 0


def _viewer_skills(env, policy) -> int:
    """A dataset policy in the viewer: keys 1 to 9 switch the skill; a fall restarts that skill."""
    import mujoco.viewer

    from mjxmimic.portable.skills import check_selectable, skill_for_key

    check_selectable(env)
    pending: list[int] = []
    print("keys: " + ", ".join(f"{i + 1} {c.name}" for i, c in enumerate(env.clips[:9])))

    def on_key(keycode: int) -> None:
        skill = skill_for_key(keycode, len(env.clips))
        if skill is not None:
            pending.append(skill)

    with mujoco.viewer.launch_passive(env.model, env.data, key_callback=on_key) as viewer:
        obs, clock = env.reset_at(0.0), _RealTime(env.control_dt)
        while viewer.is_running():
            if pending:
                obs = env.switch(pending.pop())
                pending.clear()
            s = env.step(policy(obs))
            obs = env.reset_at(0.0, clip=env.motion.clip) if s.failed else s.obs
            viewer.sync()
            clock.wait()
    return 0


def _skill_sequence(args: argparse.Namespace, pf, env) -> int:
    from mjxmimic.portable.skills import parse_sequence, play_sequence

    sequence = parse_sequence(args.skill_sequence, [c.name for c in env.clips])
    result = {"policy": str(pf.path), "sequence": args.skill_sequence, **play_sequence(env, pf.policy(), sequence)}
    if args.json:
        print(json.dumps(result))
        return 0
    print(f"{pf.path}: {args.skill_sequence}, MuJoCo CPU; "
          f"{'fell' if result['fell'] else 'stayed up'} after {result['survived_s']:.1f} of {result['seconds']:g} s")
    for seg in result["segments"]:
        print(f"  {seg['skill']:<20} {seg['survived_s']:5.1f} of {seg['seconds']:g} s, imitation reward "
              f"{seg['imitation_reward']:.3f}, pose error {seg['pose_error_rad']:.3f} rad")
    return 0


def _switch_trials(args: argparse.Namespace, pf, env) -> int:
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable.skills import switch_trials

    if args.switch_trials < 1:
        raise UserError(f"--switch-trials {args.switch_trials}: must be at least 1")
    if not args.switch_lead >= 0:
        raise UserError(f"--switch-lead {args.switch_lead}: must be at least 0 (seconds)")
    result = {"policy": str(pf.path), **switch_trials(env, pf.policy(), args.switch_trials, args.switch_lead)}
    if args.json:
        print(json.dumps(result))
        return 0
    print(f"{pf.path}: switches that hold {result['hold_s']:g} s, {result['entry']} entry, "
          f"{result['lead_s']:g} s of the first skill before, MuJoCo CPU")
    for pair, row in result["pairs"].items():
        print(f"  {pair:<30} {row['held']:>3} of {args.switch_trials}")
    print(f"  {'all pairs':<30} {result['held']:>3} of {result['trials']}")
    for pair, via in result["routes"].items():
        print(f"  routed: {pair} through {via}")
    return 0


def _push(args: argparse.Namespace, pf, env, policy, clip) -> int:
    from mjxmimic.commands.evaluate import print_push_table
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable.push_playback import push_test

    if args.trials < 1:
        raise UserError(f"--trials {args.trials}: must be at least 1")
    say = None if args.json else (lambda line: print(f"  {line}", flush=True))
    seed = 0 if args.seed is None else args.seed
    result = {"policy": str(pf.path), "clip": clip.name, **push_test(env, policy, args.trials, seed, say, args.workers)}
    if args.json:
        print(json.dumps(result))
    else:
        print_push_table(f"{pf.path} on {clip.name}, {result['simulator']}", result)
    return 0


def run(args: argparse.Namespace) -> int:
    character_option.check(args.character, args.policy)
    from mjxmimic.core.errors import UserError

    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers {args.workers}: must be at least 1")
    args.workers = args.workers or os.cpu_count() or 1

    if args.viewer and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise UserError("--viewer needs a display (DISPLAY and WAYLAND_DISPLAY are unset); "
                        "run without --viewer, or make a video with `mjxmimic render`")
    if args.episodes is not None and args.episodes < 1:
        raise UserError(f"--episodes {args.episodes}: must be at least 1")
    if args.grid is not None and (args.episodes is not None or args.seed is not None or args.push or args.viewer
                                  or args.skill_sequence is not None or args.switch_trials is not None):
        raise UserError("--grid sets the start times itself; leave out --episodes, --seed, --push, --viewer, "
                        "--skill-sequence and --switch-trials")
    if args.solver_iterations is not None and args.solver_iterations < 1:
        raise UserError(f"--solver-iterations {args.solver_iterations}: must be at least 1")

    from mjxmimic.core.config import apply_overrides, playback_config
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.portable import composite
    from mjxmimic.portable.playback import evaluate

    if composite.is_composite(args.policy):
        from mjxmimic.commands import composite_report

        if args.grid is not None:
            raise UserError(f"--grid is for single policies; {args.policy} is a composite (use --episodes)")
        return composite_report.play(args, composite.read(args.policy))
    for flag, given in (("--knockdowns", args.knockdowns), ("--save-states", args.save_states),
                        ("--push-once", args.push_once), ("--seconds", args.seconds), ("--start", args.start),
                        ("--expert", args.expert), ("--temperature", args.temperature), ("--force", args.force)):
        if given is not None:
            raise UserError(f"{flag} is for composite files (mjxmimic compose); {args.policy} is a single policy")
    pf = folder.load_policy_file(args.policy)
    character = pf.character()
    clips = pf.clips()
    names = [c.name for c in clips]
    if args.clip is not None and args.clip in names:
        env = CpuEnv(playback_config(pf.config(), args.solver_iterations), character, clips, pf.weights())
        return _play_clips(args, pf, env, names.index(args.clip))
    if args.clip is not None:
        from mjxmimic.motion.clip import load_clip_source

        clip = load_clip_source(args.clip, character, args.clips_dir)
    elif len(clips) > 1:
        entry = {} if args.switch_entry is None else {"env.skill_switch_entry": args.switch_entry}
        env = CpuEnv(playback_config(apply_overrides(pf.config(), entry), args.solver_iterations), character, clips,
                     pf.weights())
        from mjxmimic.portable.skills import set_switch_options

        set_switch_options(env, args.switch_routes, args.finish_cycle)
        if args.viewer:
            return _viewer_skills(env, pf.policy())
        if args.skill_sequence is not None:
            return _skill_sequence(args, pf, env)
        if args.switch_trials is not None:
            return _switch_trials(args, pf, env)
        return _play_clips(args, pf, env, None)
    else:
        clip = clips[0]
    for flag, given in (("--skill-sequence", args.skill_sequence), ("--switch-trials", args.switch_trials),
                        ("--switch-routes", args.switch_routes), ("--finish-cycle", args.finish_cycle)):
        if given is not None:
            raise UserError(f"{flag} needs a policy trained on a dataset of clips; this one has one clip")
    env = CpuEnv(playback_config(pf.config(), args.solver_iterations), character, clip)
    policy = pf.policy()
    starts, label = _start_times(env, pf.manifest, args.episodes, args.seed, args.clip is not None, args.grid)

    if args.push:
        return _push(args, pf, env, policy, clip)
    if args.viewer:
        result = _viewer_loop(env, policy, starts)
    else:
        result = evaluate(env, policy, starts)

    ev = pf.manifest.get("training", {}).get("eval") or {}
    mjx_nr = ev.get("nr") if args.clip is None else None

    out = {
        "policy": str(pf.path),
        "clip": clip.name,
        "simulator": env.physics.simulator,
        "physics_hz": env.config.env.physics_hz,
        "substeps": env.substeps,
        "solver_iterations": [env.config.env.solver_iterations, env.config.env.ls_iterations],
        "starts": label,
        **result,
        "mjx_nr": mjx_nr,
        "mjx_episodes": ev.get("episodes") if mjx_nr is not None else None,
        "ratio": (result["nr"] / mjx_nr) if mjx_nr else None,
    }
    if args.json:
        print(json.dumps(out))
        return 0
    rows = [
        ("sim-to-sim NR (CPU)", f"{out['nr']:.4f}  (+- {out['nr_std']:.4f} over episodes)"),
        ("paper form", f"{out['nr_paper']:.4f}  (discounted by 0.95: {out['nr_paper_discounted']:.4f})"),
        ("training NR (MJX)", "n/a (not in the file)" if mjx_nr is None
         else f"{mjx_nr:.4f}  ({out['mjx_episodes']} episodes)"),
        ("ratio CPU / MJX", "n/a" if out["ratio"] is None else f"{out['ratio']:.3f}"),
        ("fall rate", f"{out['fall_rate']:.3f}"),
        ("fell from", fall_windows_text(out["fall_windows"])),
        ("mean survival (s)", f"{out['survival_s']:.2f}"),
        ("pose error (rad)", f"{out['pose_error_rad']:.4f}"),
        ("end-effector error (m)", f"{out['end_effector_error_m']:.4f}"),
        ("episodes", f"{out['episodes']}, start times: {label}"),
        ("speed", (f"{out['control_steps']:,} control steps in {out['eval_seconds']:.1f} s "
                   f"({out['steps_per_s']:,.0f}/s)")),
    ]
    width = max(len(k) for k, _ in rows)
    print(f"{pf.path} on {clip.name}, {out['simulator']}, {env.config.env.physics_hz} Hz physics, "
          f"solver iterations up to {out['solver_iterations'][0]} (line search {out['solver_iterations'][1]})")
    for key, value in rows:
        print(f"  {key:<{width}}  {value}")
    sys.stdout.flush()
    return 0
