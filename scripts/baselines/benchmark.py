"""The baselines of docs/BENCHMARK.md on one suite: oracle, random, neuro-symbolic (programs and perception
predicted), the keypose policy of all seven families and its language-blind control, each through
`samplehd evaluate --suite`, and one Markdown table of their success with 95 % Wilson intervals: per
family and level on the clean episodes, and per robustness axis and strength (strength 0: the clean twins
of that axis's variants; `*`: the variants differ from their twins, exact McNemar p < 0.05), headed by the
commands, the commit, the machine and the times.

    python scripts/baselines/benchmark.py SUITE [--out DIR] [--workers N] [--policies ...]
        [--models DIR] [--keypose DIR] [--max-episode-steps N]

--models is a folder with parser/ and perception/ (`samplehd train parser|perception --out DIR/parser`
...), or the folder of scripts/baselines/run.sh (models/ below it); --keypose the folder of
scripts/baselines/keypose_all.sh (models/keypose_all, and models/keypose_all_blind with BLIND=1). A
learned baseline whose models are missing is skipped with a line saying how to train them. Finished
reports are kept: run it again and only what is missing runs.

Writes DIR/reports/NAME.json (and evaluate's NAME.md, NAME.robustness.png) and DIR/baselines.md.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from samplehd.bench.provenance import machine_description, measured_commit
from samplehd.benchmark.statistics import proportion
from samplehd.benchmark.tables import format_rate, markdown_table
from samplehd.envs.suite_file import Suite, read_suite

POLICIES = ("oracle", "random", "neurosymbolic", "keypose", "keypose_blind")


def _ns_models(folder: Path) -> Path:
    """The folder holding parser/ and perception/: FOLDER itself or FOLDER/models."""
    for models in (folder, folder / "models"):
        if all((models / part).is_dir() for part in ("parser", "perception")):
            return models
    raise FileNotFoundError(f"{folder}/parser and perception (train with scripts/baselines/run.sh {folder})")


def _flags(policy: str, args: argparse.Namespace) -> list[str]:
    """The evaluate flags of a baseline; raises FileNotFoundError naming the missing models."""
    if policy in ("oracle", "random"):
        return ["--policy", policy]
    if policy == "neurosymbolic":
        return ["--policy", "neurosymbolic", "--models", str(_ns_models(Path(args.models))),
                "--programs", "predicted", "--perception", "predicted"]
    blind = "_blind" if policy == "keypose_blind" else ""
    model = Path(args.keypose) / "models" / f"keypose_all{blind}"
    if not (model / "model.pt").is_file():
        raise FileNotFoundError(f"{model / 'model.pt'} (train with {'BLIND=1 ' if blind else ''}"
                                f"scripts/baselines/keypose_all.sh {args.keypose})")
    return ["--policy", "bc", "--models", str(model)]


def _groups(suite: Suite, records: Sequence[Mapping[str, Any]]) -> dict[tuple[str, str], list[bool]]:
    """(group, strength) -> the successes of its episodes: all, each family and level on the clean episodes,
    and per axis its twins (strength 0) and its variants at each strength."""
    clean = [r for r in records if suite.episodes[r["index"]].axis == "none"]
    groups: dict[tuple[str, str], list[bool]] = {("all (clean)", "0"): [bool(r["success"]) for r in clean]}
    for key in ("family", "level"):
        for value in sorted({r[key] for r in clean}):
            groups[(f"{key} {value}", "0")] = [bool(r["success"]) for r in clean if r[key] == value]
    success = {r["index"]: bool(r["success"]) for r in records}
    axes = sorted({e.axis for e in suite.episodes if e.axis != "none"})
    for axis in axes:
        variants = [e for e in suite.episodes if e.axis == axis and e.id in success]
        twins = sorted({e.twin for e in variants if e.twin is not None})
        groups[(axis, "0")] = [success[t] for t in twins if t in success]
        for strength in sorted({e.strength for e in variants}):
            groups[(axis, str(strength))] = [success[e.id] for e in variants if e.strength == strength]
    return groups


def _paired(twins: Mapping[str, Any], groups: Mapping[tuple[str, str], list[bool]], axis: str) -> str:
    """One axis of one baseline in a line: its twins' successes, then the variants' at each strength
    (``*``: they differ from their twins, exact McNemar p < 0.05)."""
    clean = groups.get((axis, "0"), [])
    strengths = sorted(twins.get(axis, {}), key=int)
    return f"{sum(clean)}/{len(clean)} → " + ", ".join(
        f"{twins[axis][k]['second']['successes']}/{twins[axis][k]['pairs']}" + ("*" if twins[axis][k]["significant"]
                                                                                else "") for k in strengths)


def _cell(successes: list[bool], significant: bool) -> str:
    return format_rate(proportion(sum(successes), len(successes)).to_dict()) + (" *" if significant else "")


def _machine() -> str:
    load = " ".join(f"{v:.1f}" for v in os.getloadavg())
    return f"{machine_description()}, load average {load} at the end"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("suite", help="a shipped suite's name or a suite file")
    parser.add_argument("--out", type=Path, default=Path("outputs/benchmark"))
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--policies", nargs="+", choices=POLICIES, default=list(POLICIES))
    parser.add_argument("--models", default="outputs/baselines",
                        help="parser/ and perception/ (or scripts/baselines/run.sh's folder)")
    parser.add_argument("--keypose", default="outputs/keypose_all", help="scripts/baselines/keypose_all.sh's folder")
    parser.add_argument("--max-episode-steps", type=int, help="evaluate's step limit (default: its own)")
    args = parser.parse_args(argv)
    suite = read_suite(args.suite)
    reports = args.out / "reports"
    reports.mkdir(parents=True, exist_ok=True)
    samplehd = [sys.executable, "-m", "samplehd"]
    commands, times, skipped = [], [], []
    columns: dict[str, dict[tuple[str, str], str]] = {}
    paired: dict[str, dict[str, str]] = {}
    for policy in args.policies:
        try:
            flags = _flags(policy, args)
        except FileNotFoundError as exc:
            skipped.append(f"{policy}: no models at {exc}")
            print(f"skipped {skipped[-1]}", file=sys.stderr)
            continue
        report = reports / f"{policy}.json"
        limit = ["--max-episode-steps", str(args.max_episode_steps)] if args.max_episode_steps else []
        command = [*samplehd, "evaluate", *flags, "--suite", args.suite, "--workers", str(args.workers), *limit,
                   "--out", str(report)]
        commands.append(shlex.join(["samplehd", *command[3:]]))
        if not report.is_file():
            print(f"running {commands[-1]}", file=sys.stderr, flush=True)
            subprocess.run(command, check=True)
        data = json.loads(report.read_text())
        if data["split"].get("content_hash") != suite.content_hash:
            raise SystemExit(f"{report}: ran another split ({data['split']}); delete it to run this suite")
        times.append(f"{policy} {data['wall_s']:.0f} s")
        twins = data["statistics"].get("twins", {})
        groups = _groups(suite, data["records"])
        columns[policy] = {
            key: _cell(successes, key[1] != "0" and bool(twins.get(key[0], {}).get(key[1], {}).get("significant")))
            for key, successes in groups.items()}
        paired[policy] = {axis: _paired(twins, groups, axis) for axis in sorted(twins)}
    keys = list(dict.fromkeys(k for column in columns.values() for k in column))
    rows = [[group, strength, *(column.get((group, strength), "–") for column in columns.values())]
            for group, strength in keys]
    head = [f"Suite `{suite.name}` ({len(suite.episodes)} episodes, {suite.content_hash}); samplehd commit "
            f"{measured_commit()}; {_machine()}.", "", "Wall time: " + ", ".join(times) + ".", "", "```bash",
            *commands, "```", ""]
    if skipped:
        head += ["Skipped: " + "; ".join(skipped) + ".", ""]
    table = markdown_table(["group", "strength", *columns], rows)
    axes = sorted({axis for column in paired.values() for axis in column})
    if axes:
        table += ("\n\nPer axis, each baseline's clean twins → its variants at strengths 1–5 (successes/pairs; "
                  "`*`: exact McNemar p < 0.05 against the twins):\n\n"
                  + markdown_table(["axis", *paired], [[a, *(c.get(a, "–") for c in paired.values())] for a in axes]))
    (args.out / "baselines.md").write_text("\n".join([*head, table, ""]))
    print("\n".join([*head, table]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
