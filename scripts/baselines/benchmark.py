"""The baselines of docs/BENCHMARK.md on one suite: oracle, random, neuro-symbolic (programs and perception
predicted), keypose (pick_up, place) and the language-blind keypose control, each through `samplehd
evaluate --suite`, and one Markdown table of their success with 95 % Wilson intervals per family, axis and
strength, headed by the commands, the commit, the machine and the times.

    python scripts/baselines/benchmark.py SUITE [--out DIR] [--workers N] [--policies ...]
        [--models DIR] [--keypose DIR] [--max-episode-steps N]

--models is the folder of scripts/baselines/run.sh (parser/ and perception/ in models/ below it);
--keypose the folder of scripts/baselines/keypose.sh (models/keypose_FAMILY), and of
`BLIND=1 scripts/baselines/keypose.sh` for the control (models/keypose_blind_FAMILY). A learned baseline
whose models are missing is skipped with a line saying how to train them. A keypose policy acts on every
episode of the suite (a suite fixes its episodes), and only its own family's episodes enter the table.
Finished reports are kept: run it again and only what is missing runs.

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
from samplehd.envs.suite_file import read_suite

KEYPOSE_FAMILIES = ("pick_up", "place")
POLICIES = ("oracle", "random", "neurosymbolic", "keypose", "keypose_blind")
HERE = Path(__file__).resolve().parent


def _runs(policy: str, args: argparse.Namespace) -> list[tuple[str, list[str], str | None]]:
    """(report name, evaluate flags, family the table keeps or None) of each evaluation of a baseline;
    raises FileNotFoundError naming the missing models."""
    if policy in ("oracle", "random"):
        return [(policy, ["--policy", policy], None)]
    if policy == "neurosymbolic":
        models = Path(args.models) / "models"
        for part in ("parser", "perception"):
            if not (models / part).is_dir():
                raise FileNotFoundError(f"{models / part} (train with scripts/baselines/run.sh {args.models})")
        return [(policy, ["--policy", "neurosymbolic", "--models", str(models), "--programs", "predicted",
                          "--perception", "predicted"], None)]
    blind = "_blind" if policy == "keypose_blind" else ""
    runs = []
    for family in KEYPOSE_FAMILIES:
        model = Path(args.keypose) / "models" / f"keypose{blind}_{family}"
        if not (model / "model.pt").is_file():
            how = f"{'BLIND=1 ' if blind else ''}FAMILIES={family} scripts/baselines/keypose.sh {args.keypose}"
            raise FileNotFoundError(f"{model / 'model.pt'} (train with {how})")
        runs.append((f"{policy}_{family}", ["--policy", "bc", "--models", str(model)], family))
    return runs


def _rows(name: str, records: Sequence[Mapping[str, Any]]) -> list[list[str]]:
    """Per family (clean episodes) and per axis × strength: the baseline's success with its interval."""
    def rate(rs: Sequence[Mapping[str, Any]]) -> str:
        return format_rate(proportion(sum(bool(r["success"]) for r in rs), len(rs)).to_dict())

    clean = [r for r in records if r.get("axis") in (None, "none")]
    rows = [[name, "all (clean)", "0", rate(clean)]]
    rows += [[name, f"family {f}", "0", rate([r for r in clean if r["family"] == f])]
             for f in sorted({r["family"] for r in clean})]
    for axis in sorted({r["axis"] for r in records if r.get("axis") not in (None, "none")}):
        for strength in sorted({int(r["strength"]) for r in records if r.get("axis") == axis}):
            rows.append([name, axis, str(strength),
                         rate([r for r in records if r.get("axis") == axis and int(r["strength"]) == strength])])
    return rows


def _machine() -> str:
    load = " ".join(f"{v:.1f}" for v in os.getloadavg())
    return f"{machine_description()}, load average {load} at the end"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("suite", help="a shipped suite's name or a suite file")
    parser.add_argument("--out", type=Path, default=Path("outputs/benchmark"))
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--policies", nargs="+", choices=POLICIES, default=list(POLICIES))
    parser.add_argument("--models", default="outputs/baselines", help="scripts/baselines/run.sh's folder")
    parser.add_argument("--keypose", default="outputs/keypose", help="scripts/baselines/keypose.sh's folder")
    parser.add_argument("--max-episode-steps", type=int, help="evaluate's step limit (default: its own)")
    args = parser.parse_args(argv)
    suite = read_suite(args.suite)
    reports = args.out / "reports"
    reports.mkdir(parents=True, exist_ok=True)
    samplehd = [sys.executable, "-m", "samplehd"]
    commands, rows, times, skipped = [], [], [], []
    for policy in args.policies:
        try:
            runs = _runs(policy, args)
        except FileNotFoundError as exc:
            skipped.append(f"{policy}: no models at {exc}")
            print(f"skipped {skipped[-1]}", file=sys.stderr)
            continue
        records: list[Mapping[str, Any]] = []
        for name, flags, family in runs:
            report = reports / f"{name}.json"
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
            times.append(f"{name} {data['wall_s']:.0f} s")
            records += [r for r in data["records"] if family is None or r["family"] == family]
        rows += _rows(policy, records)
    head = [f"Suite `{suite.name}` ({len(suite.episodes)} episodes, {suite.content_hash}); samplehd commit "
            f"{measured_commit()}; {_machine()}.", "", "Wall time: " + ", ".join(times) + ".", "", "```bash",
            *commands, "```", ""]
    if skipped:
        head += ["Skipped: " + "; ".join(skipped) + ".", ""]
    table = markdown_table(["baseline", "group", "strength", "success [95 % Wilson]"], rows)
    (args.out / "baselines.md").write_text("\n".join([*head, table, ""]))
    print("\n".join([*head, table]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
