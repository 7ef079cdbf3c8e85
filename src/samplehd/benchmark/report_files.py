"""An evaluation report with its statistics, and the files beside it: ``NAME.json`` gains a
``statistics`` section, ``NAME.md`` holds its tables and, when episodes carry robustness axes,
``NAME.robustness.png`` its curves."""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from samplehd.benchmark.curves import write_robustness_png
from samplehd.benchmark.statistics import summarize
from samplehd.benchmark.tables import statistics_markdown

__all__ = ["companion_paths", "report_title", "with_statistics", "write_report_with_statistics"]


def with_statistics(report: Mapping[str, Any]) -> dict[str, Any]:
    """The report with ``statistics`` (:func:`summarize` of its records) placed before its records."""
    out = {k: v for k, v in report.items() if k not in ("statistics", "records")}
    out["statistics"] = summarize(report.get("records", []))
    if "records" in report:
        out["records"] = report["records"]
    return out


def report_title(report: Mapping[str, Any]) -> str:
    """``oracle on seed 0, 12 episodes (place, stack), level L2`` or ``oracle on suite core, 1400 episodes``
    (a suite named in the report's ``split``)."""
    split = report.get("split") or {}
    suite = split.get("suite") or report.get("suite")
    if isinstance(suite, Mapping):
        suite = suite.get("name")
    if suite:
        where = f"suite {suite}, {split.get('episodes')} episodes"
    else:
        families = ", ".join(split.get("families") or [])
        where = f"seed {split.get('seed')}, {split.get('episodes')} episodes ({families})"
        if split.get("level"):
            where += f", level {split['level']}"
    return f"{report.get('policy', '?')} on {where}"


def companion_paths(out: str | Path) -> dict[str, Path]:
    """The files beside a report ``NAME.json``: ``markdown`` (NAME.md) and ``curves`` (NAME.robustness.png)."""
    path = Path(out)
    stem = path.with_suffix("") if path.suffix == ".json" else path
    return {"markdown": stem.with_name(stem.name + ".md"), "curves": stem.with_name(stem.name + ".robustness.png")}


def write_report_with_statistics(report: Mapping[str, Any], out: str | Path) -> dict[str, Any]:
    """Write the report with its statistics to ``out`` (atomically, as the evaluation writes it), its
    Markdown tables beside it and, when its episodes carry axes, its robustness curves.

    Returns:
        The report with ``statistics``.
    """
    full = with_statistics(report)
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(json.dumps(full, indent=1) + "\n", encoding="utf-8")
    tmp.replace(path)
    companions = companion_paths(path)
    title = report_title(full)
    companions["markdown"].write_text(statistics_markdown(full["statistics"], f"Evaluation: {title}"),
                                      encoding="utf-8")
    curves = full["statistics"].get("curves")
    if curves:
        write_robustness_png(companions["curves"], curves, f"Success against strength, 95 % Wilson band: {title}")
    return full
