"""The family x level table of evaluation reports (``samplehd evaluate --suite ... --out`` or ``--level ...
--out``), each cell
successes / n with its 95 % Wilson interval (:mod:`samplehd.benchmark.statistics`; the row ``all``
pools each column's reports), and per report the successes reached after a retry and how often the
rule of grounding by exclusion fired.

usage: python scripts/baselines/keypose_table.py REPORT.json [...]   (missing files are skipped; the
       Python that has samplehd)
"""

from __future__ import annotations

import json
import sys
from collections import defaultdict
from pathlib import Path

from samplehd.benchmark.statistics import proportion


def _cell(successes: int, n: int) -> str:
    rate = proportion(successes, n)
    return f"{successes}/{n} ({100 * rate.low:.0f}-{100 * rate.high:.0f} %)"


def _blind(report: dict) -> bool:
    """Whether a report's policy is the language-blind control (its model's configuration says so)."""
    config = Path(str(report.get("models") or "")) / "config.json"
    return config.is_file() and json.loads(config.read_text()).get("language") == "blank"


def main(paths: list[str]) -> int:
    rows: dict[str, dict[str, str]] = {}
    totals: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    notes = []
    for path in (Path(p) for p in paths if Path(p).is_file()):
        report = json.loads(path.read_text())
        if "statistics" not in report:  # a report still being written
            continue
        policy = {"bc": "keypose"}.get(str(report.get("policy")), str(report.get("policy")))
        if policy == "keypose" and _blind(report):
            policy = "keypose-blind"
        # a report of a suite's episodes covers every level (its family x level cells); one of a drawn
        # split covers the level it was drawn at
        cells = {family: {str(level): rate for level, rate in levels.items()}
                 for family, levels in report["statistics"].get("by_family_level", {}).items()}
        if not cells:
            level = str(report["records"][0].get("level") or "plain") if report["records"] else "plain"
            cells = {family: {level: rate} for family, rate in report["statistics"]["by_family"].items()}
        for family, levels in cells.items():
            for level, rate in levels.items():
                column = f"{policy} {level}"
                rows.setdefault(family, {})[column] = _cell(rate["successes"], rate["n"])
                totals[column][0] += rate["successes"]
                totals[column][1] += rate["n"]
        fired = sum(bool((r.get("diagnosis") or {}).get("exclusion")) for r in report["records"])
        retried = sum(r["success"] and bool((r.get("diagnosis") or {}).get("retries")) for r in report["records"])
        split = report.get("split") or {}
        where = f" on suite {split['suite']} ({split['content_hash']})" if split.get("suite") else ""
        notes.append(f"{path.name}{where}: {report['successes']}/{report['episodes']}, after a retry {retried}, "
                     f"exclusion fired {fired}/{report['episodes']}, {report.get('wall_s', 0):.0f} s")
    rows["all"] = {c: _cell(*t) for c, t in totals.items()}
    columns = sorted({c for r in rows.values() for c in r}, key=lambda c: (c.split()[1], c.split()[0]))
    print("| family | " + " | ".join(columns) + " |")
    print("|---" * (len(columns) + 1) + "|")
    for family in sorted(rows, key=lambda f: (f == "all", f)):
        print(f"| {family} | " + " | ".join(rows[family].get(c, "") for c in columns) + " |")
    print("\n".join(notes))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
