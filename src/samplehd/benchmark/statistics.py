"""Success rates with their uncertainty, and paired comparisons of success.

Three estimators, chosen because they behave at the edges benchmark figures live at (0 %, 100 %, a
few dozen episodes):

- a success rate ``k/n`` gets the **Wilson score interval** (Wilson 1927), which stays inside [0, 1]
  and keeps its coverage near 0 and 1 where the textbook Wald interval collapses to a point;
- the difference of two success rates measured on the **same episodes** (a policy against another on
  one split, or a perturbed episode against its clean twin) gets **Newcombe's hybrid score interval for
  paired proportions** (Newcombe 1998, *Statistics in Medicine* 17:2635, method 10), which combines
  the two Wilson intervals with the pairs' correlation;
- whether the two differ at all gets the **exact two-sided McNemar test**: under "no difference" the
  discordant pairs (success in one, failure in the other) split 50/50, so the p-value is a binomial
  tail on them, doubled and capped at 1. Concordant pairs carry no information about the difference.

Records are the evaluation report's records (plain dicts, the evaluation's ``EpisodeRecord.to_dict``);
:func:`summarize` groups them by whatever of ``family``, ``level``, ``axis`` and ``strength`` they
carry. A record without an ``axis`` (or with axis ``none``) belongs to the clean split (:data:`CLEAN`,
strength 0). A perturbed record names its clean twin by the twin's episode id in ``twin``; an episode's
id is its ``id`` when it has one, else its ``index``.

Pure Python (``math``, ``statistics.NormalDist``): the same figures on every machine.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from statistics import NormalDist
from typing import Any

__all__ = ["AXIS_KEY", "CLEAN", "CONFIDENCE", "ID_KEYS", "METHODS", "SIGNIFICANCE", "STRENGTH_KEY", "TWIN_KEY",
           "PairedDifference", "Proportion", "axis_of", "episode_id", "mcnemar_exact_p", "paired_difference",
           "proportion", "robustness_curves", "strength_of", "summarize", "twin_pairs", "wilson_interval"]

CONFIDENCE = 0.95
SIGNIFICANCE = 0.05
AXIS_KEY, STRENGTH_KEY, TWIN_KEY = "axis", "strength", "twin"
ID_KEYS = ("id", "index")
CLEAN = "clean"
_CLEAN_AXES = (None, "", "none", CLEAN)  # how records may say "no axis" (suite episodes: ``none``)
METHODS = {
    "interval": "Wilson score interval, 95 %",
    "paired_difference": "Newcombe (1998) hybrid score interval for paired proportions (method 10), 95 %",
    "p_value": "exact two-sided McNemar test (binomial on the discordant pairs)",
}


def _z(confidence: float) -> float:
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence={confidence!r}: expected a number between 0 and 1, e.g. 0.95")
    return NormalDist().inv_cdf(0.5 + confidence / 2.0)


def wilson_interval(successes: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Wilson score interval of a success rate.

    Args:
        successes: successes ``k`` (0 ≤ k ≤ n).
        n: trials; with none the interval is the whole of [0, 1] (nothing is known).
        confidence: coverage of the interval (0.95: the 95 % interval).

    Returns:
        (low, high), both in [0, 1].
    """
    if n < 0 or not 0 <= successes <= n:
        raise ValueError(f"successes={successes}, n={n}: expected 0 <= successes <= n")
    if n == 0:
        return 0.0, 1.0
    z = _z(confidence)
    p = successes / n
    z2n = z * z / n
    centre = (p + z2n / 2.0) / (1.0 + z2n)
    half = z / (1.0 + z2n) * math.sqrt(p * (1.0 - p) / n + z2n / (4.0 * n))
    # At k = 0 and k = n the formula's bound is the rate itself; rounding must not step past it.
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == n else min(1.0, centre + half)
    return low, high


@dataclass(frozen=True)
class Proportion:
    """A success rate with its Wilson interval.

    Attributes:
        successes: successful episodes.
        n: episodes.
        rate: successes / n (None without episodes).
        low: lower bound of the interval.
        high: upper bound of the interval.
    """

    successes: int
    n: int
    rate: float | None
    low: float
    high: float

    def to_dict(self) -> dict[str, object]:
        return {"successes": self.successes, "n": self.n, "rate": self.rate, "low": self.low, "high": self.high}


def proportion(successes: int, n: int, confidence: float = CONFIDENCE) -> Proportion:
    """``successes`` of ``n`` as a :class:`Proportion` with its Wilson interval."""
    low, high = wilson_interval(successes, n, confidence)
    return Proportion(successes, n, successes / n if n else None, low, high)


def mcnemar_exact_p(first_only: int, second_only: int) -> float:
    """Exact two-sided McNemar p-value.

    Args:
        first_only: pairs where only the first member succeeded (``b``).
        second_only: pairs where only the second member succeeded (``c``).

    Returns:
        ``min(1, 2 P(X <= min(b, c)))`` for ``X ~ Binomial(b + c, 1/2)``; 1.0 without discordant pairs.
    """
    if first_only < 0 or second_only < 0:
        raise ValueError(f"first_only={first_only}, second_only={second_only}: expected counts >= 0")
    n = first_only + second_only
    if n == 0:
        return 1.0
    k = min(first_only, second_only)
    if 2 * k >= n - 1:  # the smaller count is at (or next to) the middle: the doubled tail reaches 1
        return 1.0
    # Integer arithmetic (C(n, i + 1) from C(n, i)) and one correctly rounded division: exact for any
    # number of pairs, the same bits on every machine.
    term = tail = 1
    for i in range(k):
        term = term * (n - i) // (i + 1)
        tail += term
    return min(1.0, (2 * tail) / (1 << n))


@dataclass(frozen=True)
class PairedDifference:
    """The difference in success rate between the two members of paired episodes (second − first).

    Attributes:
        pairs: number of pairs.
        both: pairs where both succeeded.
        first_only: pairs where only the first succeeded.
        second_only: pairs where only the second succeeded.
        neither: pairs where neither succeeded.
        first: the first members' success rate and interval.
        second: the second members' success rate and interval.
        difference: second rate − first rate (None without pairs).
        low: lower bound of the difference's interval (Newcombe's method 10).
        high: upper bound of the difference's interval.
        p_value: exact two-sided McNemar p-value.
        significant: ``p_value < SIGNIFICANCE`` (0.05).
    """

    pairs: int
    both: int
    first_only: int
    second_only: int
    neither: int
    first: Proportion
    second: Proportion
    difference: float | None
    low: float
    high: float
    p_value: float
    significant: bool

    def to_dict(self) -> dict[str, object]:
        return {"pairs": self.pairs, "both": self.both, "first_only": self.first_only,
                "second_only": self.second_only, "neither": self.neither, "first": self.first.to_dict(),
                "second": self.second.to_dict(), "difference": self.difference, "low": self.low,
                "high": self.high, "p_value": self.p_value, "significant": self.significant}


def paired_difference(pairs: Iterable[tuple[bool, bool]], confidence: float = CONFIDENCE) -> PairedDifference:
    """Difference in success rate of paired episodes, its interval and McNemar's exact p-value.

    Args:
        pairs: (first succeeded, second succeeded) per pair.
        confidence: coverage of the intervals.

    Returns:
        The :class:`PairedDifference` of second − first. Without pairs the difference is None and its
        interval [−1, 1].
    """
    a = b = c = d = 0
    for first, second in pairs:
        if first and second:
            a += 1
        elif first:
            b += 1
        elif second:
            c += 1
        else:
            d += 1
    n = a + b + c + d
    p_first, p_second = proportion(a + b, n, confidence), proportion(a + c, n, confidence)
    p_value = mcnemar_exact_p(b, c)
    if n == 0:
        return PairedDifference(0, 0, 0, 0, 0, p_first, p_second, None, -1.0, 1.0, p_value, False)
    # Newcombe (1998) method 10, written for theta = p1 - p1' with p1 = the rate we call "second".
    p1, l1, u1 = a + c, p_second.low, p_second.high
    p2, l2, u2 = a + b, p_first.low, p_first.high
    p1, p2 = p1 / n, p2 / n
    # The pairs' correlation, with Newcombe's continuity correction: a positive association within n/2
    # of none counts as none, a larger one is reduced by n/2, a negative one is kept as it is.
    denominator = (a + b) * (c + d) * (a + c) * (b + d)
    association = a * d - b * c
    if association > n / 2:
        association -= n / 2
    elif association >= 0:
        association = 0
    phi = association / math.sqrt(denominator) if denominator else 0.0
    dl = (p1 - l1) ** 2 - 2.0 * phi * (p1 - l1) * (u2 - p2) + (u2 - p2) ** 2
    du = (u1 - p1) ** 2 - 2.0 * phi * (u1 - p1) * (p2 - l2) + (p2 - l2) ** 2
    diff = (c - b) / n
    low = max(-1.0, diff - math.sqrt(max(dl, 0.0)))
    high = min(1.0, diff + math.sqrt(max(du, 0.0)))
    return PairedDifference(n, a, b, c, d, p_first, p_second, diff, low, high, p_value, p_value < SIGNIFICANCE)


def episode_id(record: Mapping[str, Any]) -> Any:
    """A record's episode id: its ``id``, else its ``index`` (None when it has neither)."""
    for key in ID_KEYS:
        if record.get(key) is not None:
            return record[key]
    return None


def axis_of(record: Mapping[str, Any]) -> str:
    """A record's robustness axis, :data:`CLEAN` for a record without one."""
    axis = record.get(AXIS_KEY)
    return CLEAN if axis in _CLEAN_AXES else str(axis)


def strength_of(record: Mapping[str, Any]) -> int:
    """A record's strength on its axis (0: clean)."""
    strength = record.get(STRENGTH_KEY)
    return 0 if strength is None or axis_of(record) == CLEAN else int(strength)


def _rate(records: Sequence[Mapping[str, Any]], confidence: float) -> Proportion:
    return proportion(sum(bool(r["success"]) for r in records), len(records), confidence)


def _grouped(records: Sequence[Mapping[str, Any]], key: Any) -> dict[Any, list[Mapping[str, Any]]]:
    groups: dict[Any, list[Mapping[str, Any]]] = {}
    for r in records:
        groups.setdefault(key(r), []).append(r)
    return groups


def twin_pairs(records: Sequence[Mapping[str, Any]]) -> dict[str, dict[int, list[tuple[bool, bool]]]]:
    """(clean twin succeeded, perturbed episode succeeded) per axis and strength.

    A record with a ``twin`` is paired with the record whose episode id is that twin; a record whose twin
    is not among ``records`` is left out.
    """
    by_id = {episode_id(r): r for r in records if episode_id(r) is not None}
    out: dict[str, dict[int, list[tuple[bool, bool]]]] = {}
    for r in records:
        twin = by_id.get(r.get(TWIN_KEY)) if r.get(TWIN_KEY) is not None else None
        if twin is None or twin is r:
            continue
        out.setdefault(axis_of(r), {}).setdefault(strength_of(r), []).append(
            (bool(twin["success"]), bool(r["success"])))
    return out


def robustness_curves(records: Sequence[Mapping[str, Any]],
                      confidence: float = CONFIDENCE) -> dict[str, list[dict[str, Any]]]:
    """Success against strength per robustness axis, each point a :class:`Proportion` dict with its
    ``strength``.

    Strength 0 of an axis is its own strength-0 records when it has some, else the distinct clean twins
    its episodes name, else the clean split (the records without an axis); an axis without any of them
    starts at its lowest strength.
    """
    axes = _grouped([r for r in records if axis_of(r) != CLEAN], axis_of)
    clean = [r for r in records if axis_of(r) == CLEAN]
    by_id = {episode_id(r): r for r in records if episode_id(r) is not None}
    out: dict[str, list[dict[str, Any]]] = {}
    for axis in _sorted_keys(axes):
        strengths = _grouped(axes[axis], strength_of)
        if 0 not in strengths:
            twins = {id(by_id[r[TWIN_KEY]]): by_id[r[TWIN_KEY]] for r in axes[axis] if r.get(TWIN_KEY) in by_id}
            zero = list(twins.values()) or clean
            if zero:
                strengths[0] = zero
        out[axis] = [{"strength": s, **_rate(strengths[s], confidence).to_dict()} for s in sorted(strengths)]
    return out


def _sorted_keys(keys: Iterable[Any]) -> list[Any]:
    return sorted(keys, key=lambda k: (k == CLEAN, str(k)))


def summarize(records: Sequence[Mapping[str, Any]], confidence: float = CONFIDENCE) -> dict[str, Any]:
    """The statistics section of an evaluation report.

    Args:
        records: the report's records (each with ``success`` and ``family``; ``level``, ``axis``,
            ``strength``, ``twin`` and ``id`` where they apply).
        confidence: coverage of every interval.

    Returns:
        A JSON-ready dict: ``methods`` (the estimators, named), ``confidence``, ``overall``,
        ``by_family``, and where the records carry them ``by_level``, ``by_family_level``, ``by_axis``
        (axis → strength → rate; strengths are string keys, the clean split is ``clean``/``0``),
        ``curves`` (:func:`robustness_curves`) and
        ``twins`` (axis → strength → the paired difference perturbed − clean twin). Each rate is a
        :class:`Proportion` dict; each paired difference a :class:`PairedDifference` dict.
    """
    out: dict[str, Any] = {"methods": dict(METHODS), "confidence": confidence,
                           "overall": _rate(records, confidence).to_dict()}
    out["by_family"] = {fam: _rate(rs, confidence).to_dict()
                        for fam, rs in sorted(_grouped(records, lambda r: str(r.get("family"))).items())}
    if any(r.get("level") is not None for r in records):
        levels = _grouped(records, lambda r: str(r.get("level")))
        out["by_level"] = {lvl: _rate(rs, confidence).to_dict() for lvl, rs in sorted(levels.items())}
        pairs = _grouped(records, lambda r: (str(r.get("family")), str(r.get("level"))))
        out["by_family_level"] = {fam: {lvl: _rate(pairs[fam, lvl], confidence).to_dict()
                                        for lvl in sorted({k[1] for k in pairs if k[0] == fam})}
                                  for fam in sorted({k[0] for k in pairs})}
    if any(axis_of(r) != CLEAN for r in records):
        axes = _grouped(records, axis_of)
        out["by_axis"] = {axis: {str(s): _rate(rs, confidence).to_dict()
                                 for s, rs in sorted(_grouped(axes[axis], strength_of).items())}
                          for axis in _sorted_keys(axes)}
        out["curves"] = robustness_curves(records, confidence)
    twins = twin_pairs(records)
    if twins:
        out["twins"] = {axis: {str(s): paired_difference(twins[axis][s], confidence).to_dict()
                               for s in sorted(twins[axis])}
                        for axis in _sorted_keys(twins)}
    return out
