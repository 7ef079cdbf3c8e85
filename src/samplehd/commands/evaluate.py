"""Evaluate a policy on the fixed, seeded benchmark split of samplehd/Tabletop-v0."""

from __future__ import annotations

import argparse
from pathlib import Path

from samplehd.benchmark.evaluation import DEFAULT_FAMILIES, EpisodeRecord, EvalConfig, evaluate, load_policy_module
from samplehd.benchmark.lerobot_policy import is_lerobot_policy, read_lerobot_checkpoint
from samplehd.benchmark.report_files import companion_paths
from samplehd.benchmark.tables import format_rate
from samplehd.commands._options import check_int, check_out_dir, check_out_file, config_from_options
from samplehd.dataset.outputs import check_outputs
from samplehd.envs.config import CONTROL_MODES, OBS_MODES, EnvConfig
from samplehd.envs.suite_file import read_suite
from samplehd.errors import ConfigError
from samplehd.fileio import read_json, resolve_path
from samplehd.learn.options import env_options
from samplehd.tasks.task import family_names

HELP = ("run a policy (oracle, random, neurosymbolic, bc, lerobot:CKPT or MODULE:CALLABLE) on the seeded "
        "benchmark split; JSON report")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--policy", required=True,
                        help="oracle, random, neurosymbolic, bc (learned baselines: need --models), "
                             "lerobot:CKPT (a lerobot-train checkpoint folder; needs lerobot, Python >= 3.12), "
                             "or MODULE:CALLABLE (obs -> action)")
    parser.add_argument("--models", type=Path, help="trained models: neurosymbolic: a folder with parser/ and "
                                                    "perception/; bc: the folder of `samplehd train policy`")
    parser.add_argument("--programs", choices=("gt", "predicted"),
                        help="neurosymbolic: the instruction's program (gt) or the parser's (default predicted)")
    parser.add_argument("--perception", choices=("gt", "predicted"),
                        help="neurosymbolic: the scene's annotation (gt) or the perception model's (default "
                             "predicted)")
    parser.add_argument("--level", choices=("L1", "L2", "L3", "L4"),
                        help="generalisation level: L1 seen, L2 new colour-class combinations, L3 held-out "
                             "paraphrases, L4 held-out classes (default: the plain split)")
    parser.add_argument("--suite", help="a benchmark suite (a shipped suite's name or a suite file): run its episodes "
                                        "instead of drawing a split (`samplehd suite list`)")
    parser.add_argument("--episodes", type=int, help="episodes of the split (default 10)")
    parser.add_argument("--families", nargs="+", choices=family_names(), metavar="FAMILY",
                        help=f"families, in rotation (default: {' '.join(DEFAULT_FAMILIES)}; lerobot:CKPT: the "
                             "families of its training data)")
    parser.add_argument("--seed", type=int, help="seed of the split (default 0)")
    # These default to the --env-options file's values, then to Tabletop-v0's defaults.
    parser.add_argument("--control-mode", choices=list(CONTROL_MODES), help="action interface (default steering)")
    parser.add_argument("--obs-mode", choices=list(OBS_MODES), help="observations (default state)")
    parser.add_argument("--width", type=int, help="image width [px] (default 128)")
    parser.add_argument("--height", type=int, help="image height [px] (default 128)")
    parser.add_argument("--max-episode-steps", type=int, help="step limit (default 1500)")
    parser.add_argument("--env-options", type=Path,
                        help="JSON file with further Tabletop-v0 options (flags given on the command line win)")
    parser.add_argument("--video", type=Path, metavar="DIR", help="write one MP4 per episode here")
    parser.add_argument("--workers", type=int, default=1, help="parallel processes (default 1)")
    parser.add_argument("--compare-offline", action="store_true",
                        help="also run the offline path generator on each episode (the oracle's reference)")
    parser.add_argument("--out", type=Path, help="write the JSON report here (with its statistics), its Markdown "
                                                 "tables beside it (NAME.md) and, for episodes with robustness "
                                                 "axes, their curves (NAME.robustness.png)")


def run(args: argparse.Namespace) -> int:

    for flag, value, policies in (("--programs", args.programs, ("neurosymbolic",)),
                                  ("--perception", args.perception, ("neurosymbolic",)),
                                  ("--models", args.models, ("neurosymbolic", "bc"))):
        if value is not None and args.policy not in policies:
            raise ConfigError(f"{flag} {value}: only used with --policy {' or '.join(policies)}, not "
                              f"{args.policy!r}; leave it out")
    args.programs, args.perception = args.programs or "predicted", args.perception or "predicted"
    suite = None
    if args.suite is not None:
        for flag, value in (("--level", args.level), ("--episodes", args.episodes), ("--seed", args.seed),
                            ("--families", args.families)):
            if value is not None:
                raise ConfigError(f"{flag} {value}: a suite fixes its episodes; leave {flag} out with --suite")
        suite = read_suite(args.suite)
    args.episodes = len(suite.episodes) if suite is not None else (10 if args.episodes is None else args.episodes)
    args.seed = 0 if args.seed is None else args.seed
    env: dict = {}
    if args.env_options is not None:
        env = read_json(args.env_options, ConfigError, f"--env-options {args.env_options}")
        if not isinstance(env, dict):
            raise ConfigError(f"--env-options {args.env_options}: expected a JSON object of options")
    # A flag given on the command line overrides the file; a flag left out keeps the file's value.
    flags = {"control_mode": args.control_mode, "obs_mode": args.obs_mode, "width": args.width,
             "height": args.height, "max_episode_steps": args.max_episode_steps}
    env.update({k: v for k, v in flags.items() if v is not None})
    if args.policy == "bc" and args.models is not None:

        # The cameras, image size and control the policy was trained on; its catalogue unless the
        # --env-options file names one (to try the policy on the other catalogue's shapes).
        policy_env = env_options(args.models)
        trained_scene = policy_env.pop("scene", None)
        _refuse_env_the_policy_cannot_use(args, flags, policy_env, env)
        env.update(policy_env)
        if trained_scene and isinstance(env.get("scene", {}), dict):
            env["scene"] = {**trained_scene, **env.get("scene", {})}
    families = args.families or list(DEFAULT_FAMILIES)
    checkpoint = read_lerobot_checkpoint(args.policy) if is_lerobot_policy(args.policy) else None
    if checkpoint is not None:
        # The environment the policy was trained for; --env-options and flags refine it, and must still
        # give the images and state the policy reads.
        families = args.families or list(checkpoint.families) or families
        env = {**checkpoint.env, **env, "families": families}
    where = f"--env-options {args.env_options}" if args.env_options else "command line"
    try:
        env_config = EnvConfig.from_kwargs(**env)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    if checkpoint is not None:
        checkpoint.check_env(env)
    check_int("--seed", args.seed, 0)
    check_out_file("--out", args.out, (".json",))
    check_out_dir("--video", args.video)
    beside = companion_paths(args.out) if args.out else {}
    check_outputs({"--out": args.out, "--out (tables)": beside.get("markdown"),
                   "--out (curves)": beside.get("curves"), "--video": args.video},
                  {"--env-options": args.env_options, "--models": args.models})
    _refuse_outputs_inside_models(args)
    load_policy_module(args.policy)
    if checkpoint is not None:
        print(f"lerobot: {checkpoint.policy_type} policy {checkpoint.path}; environment from "
              f"{checkpoint.env_source}", flush=True)
    config = config_from_options(EvalConfig, policy=args.policy, episodes=args.episodes,
                                 families=tuple(families), seed=args.seed, env=env_config,
                                 video_dir=str(args.video) if args.video else None, workers=args.workers,
                                 compare_offline=args.compare_offline,
                                 models=str(args.models) if args.models else None, programs=args.programs,
                                 perception=args.perception, level=args.level, suite=args.suite)

    def show(r: EpisodeRecord) -> None:
        mark = "ok  " if r.success else "fail"
        extra = f" safety={','.join(r.safety_events)}" if r.safety_events else ""
        print(f"[{r.index + 1}/{args.episodes}] {mark} {r.family:<15} steps={r.steps:<5}"
              f"{extra} {r.instruction}", flush=True)

    if suite is not None:
        print(f"suite {suite.name}: {len(suite.episodes)} episodes, {suite.content_hash}", flush=True)
    report = evaluate(config, args.out, progress=show)
    print(f"success_rate {report.success_rate:.3f} over {report.overall.episodes} episodes "
          f"({report.wall_s:.0f} s)")
    for fam, s in report.by_family.items():
        stages = s.failures_by_stage
        print(f"  {fam:<15} {s.successes}/{s.episodes}" + (f"  failures: {stages}" if stages else ""))
    if args.out:
        print(f"wrote {args.out}")
    # Every figure with its interval (samplehd.benchmark.statistics), in the report and beside it.
    stats = report.statistics or {}
    print(f"95 % Wilson intervals: all {format_rate(stats['overall'])}")
    for name, rate in [*stats["by_family"].items(), *stats.get("by_level", {}).items()]:
        print(f"  {name:<15} {format_rate(rate)}")
    if args.out:
        print(f"wrote {beside['markdown']}" + (f" and {beside['curves']}" if stats.get("curves") else ""))
    return 0


def _refuse_env_the_policy_cannot_use(args: argparse.Namespace, flags: dict, policy_env: dict, env: dict) -> None:
    """A flag or ``--env-options`` value that differs from what the policy in ``--models`` was trained
    with is refused in one line, never silently replaced by the model's."""
    for key, want in policy_env.items():
        have = env.get(key)
        if have is None or (list(have) if isinstance(have, (list, tuple)) else have) == \
                (list(want) if isinstance(want, (list, tuple)) else want):
            continue
        said = f"--{key.replace('_', '-')} {have}" if flags.get(key) is not None else \
            f"--env-options {args.env_options}: {key}={have!r}"
        raise ConfigError(f"{said}: the policy in --models {args.models} was trained with {key}={want!r}; leave it "
                          f"out (the model's value is used) or give {want!r}")


def _refuse_outputs_inside_models(args: argparse.Namespace) -> None:
    """``--out`` and ``--video`` stay outside the model folder (docs/FORMAT.md), also through a link."""
    if args.models is None:
        return
    models = resolve_path(args.models, ConfigError, f"--models {args.models}")
    for flag, path in (("--out", args.out), ("--video", args.video)):
        if path is not None and models in resolve_path(path, ConfigError, f"{flag} {path}").parents:
            raise ConfigError(f"{flag} {path}: lies inside the model folder --models {args.models} (a model's "
                              f"folder holds only what its training wrote); choose a path outside it")
