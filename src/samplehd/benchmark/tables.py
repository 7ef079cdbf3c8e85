"""Markdown tables of an evaluation report's statistics: rates with their intervals per family, level,
axis × strength, and each axis's paired difference to its clean twins."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from samplehd.benchmark.statistics import CLEAN, SIGNIFICANCE

__all__ = ["format_difference", "format_p", "format_rate", "markdown_table", "statistics_markdown"]

_METHOD_LABELS = {"interval": "rates", "paired_difference": "paired differences", "p_value": "p-values"}


def format_rate(p: Mapping[str, Any]) -> str:
    """``43/50 86.0 % [73.8, 93.0]`` (percent, the interval in brackets); ``0/0 –`` without episodes."""
    if not p["n"]:
        return "0/0 –"
    return f"{p['successes']}/{p['n']} {100 * p['rate']:.1f} % [{100 * p['low']:.1f}, {100 * p['high']:.1f}]"


def format_difference(d: Mapping[str, Any]) -> str:
    """``-12.0 pp [-20.1, -4.2]`` (percentage points); ``–`` without pairs."""
    if d["difference"] is None:
        return "–"
    return f"{100 * d['difference']:+.1f} pp [{100 * d['low']:+.1f}, {100 * d['high']:+.1f}]"


def format_p(p_value: float) -> str:
    """A p-value with three significant digits, and ``*`` when below the significance level."""
    return f"{p_value:.3g}" + (" *" if p_value < SIGNIFICANCE else "")


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    """A GitHub Markdown table (``|`` in cells escaped)."""
    def line(cells: list[str]) -> str:
        return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"
    return "\n".join([line(header), line(["---"] * len(header)), *(line(r) for r in rows)])


def _rates(title: str, column: str, rates: Mapping[str, Mapping[str, Any]]) -> str:
    return f"## {title}\n\n" + markdown_table([column, "successes/episodes, success rate [95 % interval]"],
                                               [[k, format_rate(p)] for k, p in rates.items()])


def statistics_markdown(stats: Mapping[str, Any], title: str = "Evaluation") -> str:
    """The Markdown page of :func:`samplehd.benchmark.statistics.summarize`'s result.

    Args:
        stats: the report's ``statistics``.
        title: the page's heading (e.g. the policy and the split).

    Returns:
        Sections: overall, by family, by level, family × level, robustness (axis × strength), clean twins.
    """
    parts = [f"# {title}", f"Overall: {format_rate(stats['overall'])}.",
             "Methods: " + "; ".join(f"{_METHOD_LABELS.get(k, k)}: {v}" for k, v in stats["methods"].items()) + "."]
    parts.append(_rates("By family", "family", stats["by_family"]))
    if "by_level" in stats:
        parts.append(_rates("By level", "level", stats["by_level"]))
        levels = sorted({lvl for fams in stats["by_family_level"].values() for lvl in fams})
        rows = [[fam, *(format_rate(by[lvl]) if lvl in by else "" for lvl in levels)]
                for fam, by in stats["by_family_level"].items()]
        parts.append("## Family × level\n\n" + markdown_table(["family", *levels], rows))
    if "by_axis" in stats:
        curves = stats["curves"]
        strengths = sorted({int(p["strength"]) for pts in curves.values() for p in pts})
        rows = [[axis, *(next((format_rate(p) for p in pts if p["strength"] == s), "") for s in strengths)]
                for axis, pts in curves.items()]
        if CLEAN in stats["by_axis"]:
            rows.append([CLEAN, *(format_rate(stats["by_axis"][CLEAN]["0"]) if s == 0 else "" for s in strengths)])
        parts.append("## Robustness: axis × strength\n\nStrength 0 is the clean twin.\n\n"
                     + markdown_table(["axis", *(f"strength {s}" for s in strengths)], rows))
    if "twins" in stats:
        rows = [[axis, s, str(d["pairs"]), format_rate(d["first"]), format_rate(d["second"]), format_difference(d),
                 format_p(d["p_value"])]
                for axis, by in stats["twins"].items() for s, d in by.items()]
        parts.append(f"## Against the clean twin\n\nPerturbed − clean on the same episodes; `*`: p < {SIGNIFICANCE} "
                     "(exact McNemar, each row on its own, not corrected for the number of rows).\n\n"
                     + markdown_table(["axis", "strength", "pairs", "clean twin", "perturbed", "difference",
                                       "McNemar p"], rows))
    return "\n\n".join(parts) + "\n"
