"""Compare two evaluation reports of one split episode by episode.

Two policies evaluated on the same episodes give paired results, and a paired comparison needs far
fewer episodes than comparing two rates as if they came from different episodes: only the episodes one
policy solves and the other does not carry information. Per group (all episodes, each family, level,
axis and strength) :func:`compare_reports` gives both success rates with their Wilson intervals, the
difference B − A with Newcombe's paired interval and the exact McNemar p-value
(:mod:`samplehd.benchmark.statistics`).

Episodes are matched by their id (``id``, else ``index``); the two reports must name the same suite (or
the same split when they have no suite), hold the same episode ids, and agree on every matched
episode's seed, family and instruction, or nothing is compared.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from samplehd.benchmark.statistics import (
    CLEAN,
    SIGNIFICANCE,
    PairedDifference,
    axis_of,
    episode_id,
    paired_difference,
    strength_of,
)
from samplehd.benchmark.tables import format_difference, format_p, format_rate, markdown_table
from samplehd.errors import ConfigError

__all__ = ["GroupComparison", "check_report", "compare_reports", "comparison_markdown"]

# What must agree on a matched episode for the two results to be about the same episode.
EPISODE_KEYS = ("seed", "family", "instruction")


@dataclass(frozen=True)
class GroupComparison:
    """One group's paired comparison.

    Attributes:
        group: ``all``, ``family place``, ``level L2``, ``lighting 3`` (axis and strength).
        difference: the paired difference B − A (``first`` is A, ``second`` is B).
    """

    group: str
    difference: PairedDifference

    def to_dict(self) -> dict[str, object]:
        return {"group": self.group, **self.difference.to_dict()}


def check_report(report: Any, label: str) -> list[Mapping[str, Any]]:
    """The records of a finished evaluation report.

    Raises:
        ConfigError: ``<label>: ...`` when it is not a JSON object with a ``records`` list of objects with a
            boolean ``success`` and an episode id, or is a partial report.
    """
    if not isinstance(report, Mapping) or not isinstance(report.get("records"), list):
        raise ConfigError(f"{label}: not a samplehd evaluation report (expected a JSON object with a 'records' "
                          "list, as `samplehd evaluate --out` writes)")
    if report.get("partial"):
        raise ConfigError(f"{label}: a partial report (the evaluation was interrupted); compare finished reports")
    ids = set()
    for k, r in enumerate(report["records"]):
        if not isinstance(r, Mapping) or not isinstance(r.get("success"), bool) or episode_id(r) is None:
            raise ConfigError(f"{label}: records[{k}]: expected an object with a boolean 'success' and an 'id' or "
                              "'index'")
        if not isinstance(episode_id(r), str | int) or episode_id(r) in ids:
            raise ConfigError(f"{label}: records[{k}]: episode id {episode_id(r)!r} is not a unique string or "
                              "integer")
        ids.add(episode_id(r))
        strength, twin = r.get("strength"), r.get("twin")
        if strength is not None and (isinstance(strength, bool) or not isinstance(strength, int) or strength < 0):
            raise ConfigError(f"{label}: records[{k}]: strength {strength!r} is not a whole number >= 0")
        if twin is not None and not isinstance(twin, str | int):
            raise ConfigError(f"{label}: records[{k}]: twin {twin!r} is not an episode id (a string or integer)")
    return report["records"]


def _split_of(report: Mapping[str, Any]) -> tuple[str, Any]:
    if report.get("suite") is not None:
        return "suite", report["suite"]
    return "split", report.get("split")


def _groups(records: Sequence[Mapping[str, Any]]) -> dict[str, list[int]]:
    """Group name -> indices into ``records``, in a fixed order."""
    groups: dict[str, list[int]] = {"all": list(range(len(records)))}
    for key in ("family", "level"):
        for value in sorted({str(r[key]) for r in records if r.get(key) is not None}):
            groups[f"{key} {value}"] = [i for i, r in enumerate(records) if str(r.get(key)) == value]
    axes = sorted({(axis_of(r), strength_of(r)) for r in records if axis_of(r) != CLEAN})
    clean = [i for i, r in enumerate(records) if axis_of(r) == CLEAN]
    if axes and clean:
        groups[f"{CLEAN} 0"] = clean
    for axis, strength in axes:
        groups[f"{axis} {strength}"] = [i for i, r in enumerate(records)
                                        if axis_of(r) == axis and strength_of(r) == strength]
    return groups


def compare_reports(a: Mapping[str, Any], b: Mapping[str, Any], label_a: str = "A",
                    label_b: str = "B") -> list[GroupComparison]:
    """Pair the episodes of two reports and compare their success per group.

    Args:
        a: the first report (the baseline): ``first`` in each :class:`PairedDifference`.
        b: the second report: ``second``; differences are B − A.
        label_a: how errors name ``a`` (its file).
        label_b: how errors name ``b``.

    Raises:
        ConfigError: one line: a report is not a finished evaluation report, the two name different
            suites or splits, hold different episode ids, or a matched episode differs in seed, family
            or instruction.
    """
    records_a, records_b = check_report(a, label_a), check_report(b, label_b)
    (kind_a, split_a), (kind_b, split_b) = _split_of(a), _split_of(b)
    if (kind_a, split_a) != (kind_b, split_b):
        raise ConfigError(f"{label_a} and {label_b}: different {kind_a if kind_a == kind_b else 'suite/split'} "
                          f"({kind_a} {_short(split_a)} vs {kind_b} {_short(split_b)}); compare reports of one "
                          "split or suite")
    by_id = {episode_id(r): r for r in records_b}
    missing = [episode_id(r) for r in records_a if episode_id(r) not in by_id]
    if missing or len(records_a) != len(records_b):
        raise ConfigError(f"{label_a} and {label_b}: different episodes ({len(records_a)} vs {len(records_b)}"
                          + (f"; {missing[0]!r} only in {label_a}" if missing else "") + "); compare reports "
                          "of the same episodes")
    for r in records_a:
        other = by_id[episode_id(r)]
        for key in EPISODE_KEYS:
            if r.get(key) != other.get(key):
                raise ConfigError(f"{label_a} and {label_b}: episode {episode_id(r)!r} differs in {key} "
                                  f"({_short(r.get(key))} vs {_short(other.get(key))}): the reports ran different "
                                  "episodes (other environment options?); compare reports of the same episodes")
    paired = [(r, by_id[episode_id(r)]) for r in records_a]
    return [GroupComparison(name, paired_difference((paired[i][0]["success"], paired[i][1]["success"])
                                                    for i in indices))
            for name, indices in _groups(records_a).items()]


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def comparison_markdown(rows: Sequence[GroupComparison], name_a: str, name_b: str) -> str:
    """The comparison as a Markdown table, ``*`` marking the differences significant at 0.05."""
    table = markdown_table(
        ["group", "pairs", f"A: {name_a}", f"B: {name_b}", "B − A [95 % interval]", "McNemar p"],
        [[g.group, str(g.difference.pairs), format_rate(g.difference.first.to_dict()),
          format_rate(g.difference.second.to_dict()), format_difference(g.difference.to_dict()),
          format_p(g.difference.p_value)] for g in rows])
    significant = [g.group for g in rows if g.difference.significant]
    return (f"{table}\n\n`*`: p < {SIGNIFICANCE} (exact McNemar on the episodes one policy solves and the other "
            "does not; each row on its own, not corrected for the number of rows). Significant: "
            + (", ".join(significant) if significant else "none") + ".\n")
