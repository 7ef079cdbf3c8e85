"""Train a learned baseline on a generated dataset: the instruction parser, the perception model or
the visuomotor behaviour-cloning policy (PyTorch: `pip install 'samplehd[learn]'`).

Each run writes config.json, checkpoint.pt (resume point), model.pt and metrics.json into --out;
running the same command again after an interruption resumes from the last checkpoint. With
--evaluate-only, the parser or perception model already in --out is tested on the dataset's test split
(no training; nothing written): its test metrics go to stdout as JSON."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

from samplehd.commands._options import check_out_dir
from samplehd.dataset.outputs import check_outputs
from samplehd.errors import ConfigError, require_extra
from samplehd.learn.keypose.configuration import ACTION as KEYPOSE_ACTION
from samplehd.learn.keypose.configuration import GRASP_HEADS, KeyposeArchitecture, KeyposeConfig, KeyposeTraining
from samplehd.learn.parser import ParserConfig, ParserTraining, score_parser, train_parser
from samplehd.learn.perception import PerceptionConfig, PerceptionTraining, score_perception, train_perception
from samplehd.learn.policy.configuration import PolicyArchitecture, PolicyCollection, PolicyConfig, PolicyTraining
from samplehd.learn.registry import policy_actions, policy_for_action

HELP = "train the parser, perception or behaviour-cloning policy baseline on a dataset (needs PyTorch)"
_DEFAULT_STEPS = {"parser": 1000, "perception": 3000, "policy": 4000}
# Upper bounds of the sizes a run allocates at once (a batch of images, a layer's width).
_MAX = {"batch": 4096, "hidden": 8192}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", choices=list(_DEFAULT_STEPS), help="what to train")
    parser.add_argument("--dataset", type=Path, nargs="+", required=True, metavar="DIR",
                        help="a dataset folder written by `samplehd generate` (several: `train policy --action "
                             "keypose` learns from their episodes together)")
    parser.add_argument("--out", type=Path, required=True, help="output folder (resumes when it holds a checkpoint)")
    parser.add_argument("--steps", type=int, help="optimiser steps (default: parser 1000, perception 3000, "
                                                  "policy 4000)")
    parser.add_argument("--seed", type=int, default=0, help="seed of initialisation, batches and augmentation")
    parser.add_argument("--device", help="torch device (default: cuda when present, else cpu)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    policy = parser.add_argument_group("policy only: its inputs, and demonstrations collected in the environment "
                                       "by the oracle")
    policy.add_argument("--inputs", choices=["rgb", "state"], help="rgb: the visuomotor policy (default); state: "
                                                                   "the privileged-state reference (no image; the "
                                                                   "target object's pose relative to the TCP; "
                                                                   "keypose: the view marks the cells of the "
                                                                   "objects the task moves)")
    policy.add_argument("--action", choices=list(policy_actions()),
                        help="steering: chunks of the demonstrations' steering vectors (default); waypoint: the "
                             "TCP pose and gripper command where the current segment of the demonstration ends, "
                             "followed by a proportional controller; keypose: per object moved, where to grasp "
                             "and where it goes, from a top-down view of the scene camera's RGB-D (the dataset's "
                             "scene images; default 16 decisions per step)")
    policy.add_argument("--blind-language", action="store_true",
                        help="--action keypose: the language-blind control: the policy reads a blank instruction "
                             "('.') in training and when it acts")
    policy.add_argument("--init", type=Path, help="--action keypose: start from the weights of the keypose policy "
                                                  "in this folder (e.g. a pick_up model for place)")
    policy.add_argument("--grasp-head", choices=GRASP_HEADS,
                        help="--action keypose: film: the grasp's maps read the instruction through the "
                             "FiLM-modulated features (default); product: their heat also adds a per-cell "
                             "product of the features' key with the instruction's query")
    policy.add_argument("--placed-count", action="store_true",
                        help="--action keypose: the network also reads how many objects the policy has put "
                             "down so far in the episode (model.placed_count)")
    policy.add_argument("--batch", type=int, help="frames per optimiser step (default 64)")
    policy.add_argument("--hidden", type=int, help="width of the network's hidden layers (default 256)")
    policy.add_argument("--demos", type=int, help="oracle episodes to collect in the environment besides the "
                                                  "dataset's (default 0)")
    policy.add_argument("--noise", type=float, help="DART: std of the noise added to the executed velocities of "
                                                    "--demos episodes, the labels staying the oracle's (default 0)")
    policy.add_argument("--dagger-rounds", type=int, help="DAgger: after --steps, rounds of running the policy "
                                                          "and adding the states it visits, labelled by the oracle "
                                                          "(default 0)")
    policy.add_argument("--dagger-episodes", type=int, help="episodes per DAgger round (default 50)")
    policy.add_argument("--dagger-steps", type=int, help="optimiser steps after each DAgger round (default 1000)")
    policy.add_argument("--workers", type=int, help="processes collecting episodes (default 1)")
    parser.add_argument("--evaluate-only", action="store_true",
                        help="parser, perception: test the model already trained in --out on the dataset's test "
                             "split, without training; print its test metrics (JSON), write nothing")


def _torch_or_error() -> None:

    require_extra("torch", "learn", "samplehd train")


def run(args: argparse.Namespace) -> int:

    _torch_or_error()
    check_out_dir("--out", args.out)
    datasets = args.dataset
    if len(datasets) > 1 and (args.model != "policy" or args.action != KEYPOSE_ACTION):
        raise ConfigError(f"--dataset {' '.join(map(str, datasets))}: several datasets train only "
                          "`train policy --action keypose`; give one")
    check_outputs({"--out": args.out}, {**{f"--dataset {d}": d for d in datasets}, "--init": args.init})
    args.dataset = datasets[0] if len(datasets) == 1 else datasets
    collect = {"demos": args.demos, "noise": args.noise, "dagger_rounds": args.dagger_rounds,
               "dagger_episodes": args.dagger_episodes, "dagger_steps": args.dagger_steps, "workers": args.workers,
               "inputs": args.inputs, "action": args.action, "batch": args.batch, "hidden": args.hidden,
               "init": args.init, "grasp_head": args.grasp_head}
    given = {k: v for k, v in collect.items() if v is not None}
    if given and args.model != "policy":
        flag = "--" + next(iter(given)).replace("_", "-")
        raise ConfigError(f"{flag} {next(iter(given.values()))}: only used with `train policy`; leave it out")
    for key, value in given.items():
        if key in ("inputs", "action", "init", "grasp_head"):
            continue
        low = 1 if key in ("dagger_episodes", "dagger_steps", "workers", "batch", "hidden") else 0
        if key == "noise":
            if not 0.0 <= value <= 1.0:
                raise ConfigError(f"--noise {value}: valid: a number in [0, 1] (a fraction of the full steering "
                                  f"speed)")
        elif value < low:
            raise ConfigError(f"--{key.replace('_', '-')} {value}: valid: an integer ≥ {low}")
        elif key in _MAX and value > _MAX[key]:
            raise ConfigError(f"--{key.replace('_', '-')} {value}: valid: an integer in {low}..{_MAX[key]}")
    if given.get("action") == KEYPOSE_ACTION:
        unused = [k for k in ("hidden", "demos", "noise", "dagger_rounds", "workers") if k in given]
        if unused:
            key = unused[0]
            raise ConfigError(f"--{key.replace('_', '-')} {given[key]}: not used with --action keypose (it learns "
                              f"from the dataset's scene images and decisions); leave it out")
    keypose_only = {"--blind-language": ("", args.blind_language, "the language-blind control of the keypose policy"),
                    "--placed-count": ("", args.placed_count, "the keypose network's count of objects put down"),
                    "--grasp-head": (f" {args.grasp_head}", "grasp_head" in given, "the keypose policy's grasp head"),
                    "--init": (f" {args.init}", "init" in given, "starts a keypose policy from another's weights")}
    for flag, (value, used, what) in keypose_only.items():
        if used and given.get("action") != KEYPOSE_ACTION:
            raise ConfigError(f"{flag}{value}: {what}; only used with --action keypose")
    if given.get("noise") and not given.get("demos"):
        raise ConfigError(f"--noise {args.noise}: adds noise to --demos episodes; give --demos N or leave it out")
    for key in ("dagger_episodes", "dagger_steps"):
        if key in given and not given.get("dagger_rounds"):
            raise ConfigError(f"--{key.replace('_', '-')} {given[key]}: only used with --dagger-rounds N ≥ 1; "
                              f"leave it out")
    if args.evaluate_only:
        return _evaluate_only(args)
    steps = _DEFAULT_STEPS[args.model] if args.steps is None else args.steps
    if steps < 1:
        raise ConfigError(f"--steps {steps}: must be a positive integer")
    if args.seed < 0:
        raise ConfigError(f"--seed {args.seed}: must be ≥ 0")
    if args.model == "parser":
        metrics = train_parser(args.dataset, args.out, ParserConfig(train=ParserTraining(steps=steps, seed=args.seed)),
                               device=args.device, quiet=args.quiet)
    elif args.model == "perception":
        config = PerceptionConfig(train=PerceptionTraining(steps=steps, seed=args.seed))
        metrics = train_perception(args.dataset, args.out, config, device=args.device, quiet=args.quiet)
    else:
        entry = policy_for_action(args.action or policy_actions()[0])
        config, options = POLICY_FLAGS[entry.name](args, steps)
        metrics = entry.train_function()(args.dataset, args.out, config, device=args.device, quiet=args.quiet,
                                         **options)
    shown = {k: v for k, v in metrics.items() if not isinstance(v, (dict, list))}
    print(json.dumps(shown, indent=1))
    print(f"wrote {args.out / 'metrics.json'}")
    return 0


def _keypose_config(args: argparse.Namespace, steps: int) -> tuple[KeyposeConfig, dict[str, int]]:
    """The keypose policy to train, from the flags (what the dataset says is filled in by training), and
    no more trainer options."""
    return KeyposeConfig(
        inputs=args.inputs or "rgb",
        model=KeyposeArchitecture(grasp_head=args.grasp_head or "film", placed_count=args.placed_count),
        language="blank" if args.blind_language else "instruction",
        train=KeyposeTraining(steps=steps, seed=args.seed, batch=args.batch or 16,
                              init=str(args.init) if args.init is not None else "")), {}


def _policy_config(args: argparse.Namespace, steps: int) -> tuple[PolicyConfig, dict[str, int]]:
    """The behaviour-cloning policy to train, from the flags (what the dataset says is filled in by
    training): ``train.steps`` counts the DAgger rounds' steps after ``--steps``; and the trainer's
    ``workers``."""
    collect = PolicyCollection(**{k: v for k, v in (("demos", args.demos), ("noise", args.noise),
                                                     ("dagger_rounds", args.dagger_rounds),
                                                     ("dagger_episodes", args.dagger_episodes),
                                                     ("dagger_steps", args.dagger_steps)) if v is not None})
    return PolicyConfig(
        inputs=args.inputs or "rgb", action=args.action or "steering",
        model=PolicyArchitecture(hidden=args.hidden or 256), collect=collect,
        train=PolicyTraining(steps=steps + collect.dagger_rounds * collect.dagger_steps, seed=args.seed,
                             batch=args.batch or 64)), {"workers": args.workers or 1}


# A registered policy's name (samplehd.learn.registry) -> its config and trainer options from the flags.
POLICY_FLAGS: dict[str, Callable[[argparse.Namespace, int], tuple[PolicyConfig | KeyposeConfig, dict[str, int]]]] = {
    "bc": _policy_config, "keypose": _keypose_config}


def _evaluate_only(args: argparse.Namespace) -> int:
    if args.model == "policy":
        raise ConfigError("--evaluate-only: for parser and perception; a policy is tested in the environment "
                          "(`samplehd evaluate --policy bc --models DIR`)")
    if args.steps is not None:
        raise ConfigError(f"--steps {args.steps}: not used with --evaluate-only (the model in --out is tested as "
                          "it is)")
    score = score_parser if args.model == "parser" else score_perception
    metrics = score(args.dataset, args.out, device=args.device)
    print(json.dumps(metrics, indent=1))
    return 0
