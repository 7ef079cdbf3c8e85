"""Evaluate a policy on the fixed, seeded benchmark split of samplehd/Tabletop-v0."""

from __future__ import annotations

import argparse
from pathlib import Path

from samplehd.envs.config import CONTROL_MODES, OBS_MODES
from samplehd.envs.evaluation import DEFAULT_FAMILIES, EvalConfig, evaluate
from samplehd.errors import ConfigError
from samplehd.fileio import read_json
from samplehd.tasks.task import family_names

HELP = ("run a policy (oracle, random, neurosymbolic, bc or MODULE:CALLABLE) on the seeded benchmark split; "
        "JSON report")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--policy", required=True,
                        help="oracle, random, neurosymbolic, bc (learned baselines: need --models), or "
                             "MODULE:CALLABLE (obs -> action)")
    parser.add_argument("--models", type=Path, help="trained models: neurosymbolic: a folder with parser/ and "
                                                    "perception/; bc: the folder of `samplehd train policy`")
    parser.add_argument("--programs", choices=("gt", "predicted"), default="predicted",
                        help="neurosymbolic: the instruction's program (gt) or the parser's")
    parser.add_argument("--perception", choices=("gt", "predicted"), default="predicted",
                        help="neurosymbolic: the scene's annotation (gt) or the perception model's")
    parser.add_argument("--level", choices=("L1", "L2", "L3", "L4"),
                        help="generalisation level: L1 seen, L2 new colour-class combinations, L3 held-out "
                             "paraphrases, L4 held-out classes (default: the plain split)")
    parser.add_argument("--episodes", type=int, default=10, help="episodes of the split (default 10)")
    parser.add_argument("--families", nargs="+", default=list(DEFAULT_FAMILIES), choices=family_names(),
                        metavar="FAMILY", help=f"families, in rotation (default: {' '.join(DEFAULT_FAMILIES)})")
    parser.add_argument("--seed", type=int, default=0, help="seed of the split (default 0)")
    parser.add_argument("--control-mode", default="steering", choices=list(CONTROL_MODES),
                        help="action interface (default steering)")
    parser.add_argument("--obs-mode", default="state", choices=list(OBS_MODES), help="observations (default state)")
    parser.add_argument("--width", type=int, default=128, help="image width [px] (default 128)")
    parser.add_argument("--height", type=int, default=128, help="image height [px] (default 128)")
    parser.add_argument("--max-episode-steps", type=int, default=1500, help="step limit (default 1500)")
    parser.add_argument("--env-options", type=Path, help="JSON file with further Tabletop-v0 options")
    parser.add_argument("--video", type=Path, metavar="DIR", help="write one MP4 per episode here")
    parser.add_argument("--workers", type=int, default=1, help="parallel processes (default 1)")
    parser.add_argument("--compare-offline", action="store_true",
                        help="also run the offline path generator on each episode (the oracle's reference)")
    parser.add_argument("--out", type=Path, help="write the JSON report here")


def run(args: argparse.Namespace) -> int:
    env: dict = {}
    if args.env_options is not None:
        env = read_json(args.env_options, ConfigError, f"--env-options {args.env_options}")
        if not isinstance(env, dict):
            raise ConfigError(f"--env-options {args.env_options}: expected a JSON object of options")
    env.update(control_mode=args.control_mode, obs_mode=args.obs_mode, width=args.width, height=args.height,
               max_episode_steps=args.max_episode_steps)
    if args.policy == "bc" and args.models is not None:
        from samplehd.learn.bc import env_options

        env.update(env_options(args.models))  # the cameras, image size and control the policy was trained on
    config = EvalConfig(policy=args.policy, episodes=args.episodes, families=tuple(args.families), seed=args.seed,
                        env=env, video_dir=str(args.video) if args.video else None, workers=args.workers,
                        compare_offline=args.compare_offline,
                        models=str(args.models) if args.models else None, programs=args.programs,
                        perception=args.perception, level=args.level)

    def show(r: dict) -> None:
        mark = "ok  " if r["success"] else "fail"
        extra = f" safety={','.join(r['safety_events'])}" if r["safety_events"] else ""
        print(f"[{r['index'] + 1}/{args.episodes}] {mark} {r['family']:<15} steps={r['steps']:<5}"
              f"{extra} {r['instruction']}", flush=True)

    report = evaluate(config, args.out, progress=show)
    print(f"success_rate {report['success_rate']:.3f} over {report['episodes']} episodes "
          f"({report['wall_s']:.0f} s)")
    for fam, s in report["by_family"].items():
        stages = s.get("failures_by_stage")
        print(f"  {fam:<15} {s['successes']}/{s['episodes']}" + (f"  failures: {stages}" if stages else ""))
    if args.out:
        print(f"wrote {args.out}")
    return 0
