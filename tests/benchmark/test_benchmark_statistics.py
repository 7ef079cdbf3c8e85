"""Success rates, paired differences and McNemar's test against published and hand-computed values,
and the grouping of evaluation records by family, level, axis and strength."""

from __future__ import annotations

import json
import math

import pytest

from samplehd.benchmark.statistics import (
    CLEAN,
    mcnemar_exact_p,
    paired_difference,
    summarize,
    wilson_interval,
)


def _pairs(both: int, first_only: int, second_only: int, neither: int) -> list[tuple[bool, bool]]:
    return ([(True, True)] * both + [(True, False)] * first_only + [(False, True)] * second_only
            + [(False, False)] * neither)


def test_wilson_interval_matches_hand_computed_values() -> None:
    # 43/50: centre (0.86 + 1.96²/100) / (1 + 1.96²/50) = 0.8343, half-width 0.0962.
    low, high = wilson_interval(43, 50)
    assert low == pytest.approx(0.7381, abs=1e-4) and high == pytest.approx(0.9305, abs=1e-4)
    # Newcombe (1998), Stat Med 17:857, the score method on his four examples.
    for (k, n), published in {(81, 263): (0.2553, 0.3662), (15, 148): (0.0624, 0.1605), (0, 20): (0.0, 0.1611),
                              (1, 29): (0.0061, 0.1718)}.items():
        assert wilson_interval(k, n) == pytest.approx(published, abs=1e-4), (k, n)


def test_wilson_interval_edges() -> None:
    assert wilson_interval(0, 0) == (0.0, 1.0)
    assert wilson_interval(0, 10) == (0.0, pytest.approx(0.2775, abs=1e-4))
    low, high = wilson_interval(10, 10)
    assert high == 1.0 and low == pytest.approx(1 - 0.2775, abs=1e-4)
    assert wilson_interval(0, 1)[0] == 0.0
    for bad in ((3, 2), (-1, 2), (0, -1)):
        with pytest.raises(ValueError, match="successes"):
            wilson_interval(*bad)


def test_mcnemar_exact_p_is_the_doubled_binomial_tail() -> None:
    # b=1, c=9: 2 * (1 + 10) / 2**10.
    assert mcnemar_exact_p(1, 9) == mcnemar_exact_p(9, 1) == pytest.approx(0.021484375, abs=0)
    assert mcnemar_exact_p(6, 16) == pytest.approx(2 * 110056 / 2**22, abs=0)  # 0.0525
    assert mcnemar_exact_p(0, 0) == 1.0
    assert mcnemar_exact_p(5, 5) == 1.0  # the doubled tail passes 1 and is capped
    assert mcnemar_exact_p(0, 5) == pytest.approx(2 / 32)
    # Many pairs: exact integers, no overflow, and a vanishing p for a lopsided split.
    assert 0.0 < mcnemar_exact_p(400, 600) < 1e-9
    assert mcnemar_exact_p(5000, 5000) == 1.0 and 0.0 < mcnemar_exact_p(4800, 5200) < 1e-4
    for n in range(40):  # every split of up to 39 discordant pairs against the binomial tail written out
        for b in range(n + 1):
            k = min(b, n - b)
            tail = sum(math.comb(n, i) for i in range(k + 1))
            assert mcnemar_exact_p(b, n - b) == min(1.0, 2 * tail / 2**n), (b, n - b)


def test_paired_difference_matches_the_published_newcombe_interval() -> None:
    # Fagerland, Lydersen & Laake (2017), Cavo et al. (2012): 59 / 6 / 16 / 80 -> the difference
    # (first - second) -0.0621, Newcombe square-and-add 95 % CI -0.1186 to -0.0046. We report second - first.
    d = paired_difference(_pairs(59, 6, 16, 80))
    assert d.difference == pytest.approx(0.0621, abs=1e-4)
    assert d.low == pytest.approx(0.0046, abs=1e-4) and d.high == pytest.approx(0.1186, abs=1e-4)
    assert (d.pairs, d.both, d.first_only, d.second_only, d.neither) == (161, 59, 6, 16, 80)
    assert d.first.successes == 65 and d.second.successes == 75
    assert d.p_value == pytest.approx(0.0525, abs=1e-4) and not d.significant


def test_paired_difference_edges() -> None:
    empty = paired_difference([])
    assert empty.difference is None and (empty.low, empty.high) == (-1.0, 1.0) and empty.p_value == 1.0
    assert empty.first.rate is None and not empty.significant
    same = paired_difference(_pairs(5, 0, 0, 5))  # no discordant pairs: no evidence of a difference
    assert same.difference == 0.0 and same.p_value == 1.0 and same.low <= 0.0 <= same.high
    all_lost = paired_difference(_pairs(0, 10, 0, 0))  # every twin succeeded, every perturbed one failed
    assert all_lost.difference == -1.0 and all_lost.low == -1.0 and all_lost.high < -0.6
    assert all_lost.significant and all_lost.p_value == pytest.approx(2 / 1024)
    all_ok = paired_difference(_pairs(7, 0, 0, 0))
    assert all_ok.difference == 0.0 and all_ok.first.high == 1.0 and all_ok.low <= 0.0 <= all_ok.high
    for d in (same, all_lost, all_ok, paired_difference(_pairs(1, 1, 7, 12))):
        assert -1.0 <= d.low <= d.difference <= d.high <= 1.0


def _record(index: int, success: bool, family: str = "place", **extra: object) -> dict:
    return {"index": index, "success": success, "family": family, **extra}


def test_summarize_groups_by_family_and_level() -> None:
    records = [_record(0, True, "place", level="L1"), _record(1, False, "place", level="L2"),
               _record(2, True, "stack", level="L1"), _record(3, True, "stack", level="L1")]
    s = summarize(records)
    assert s["overall"]["successes"] == 3 and s["overall"]["n"] == 4
    assert s["by_family"]["place"]["rate"] == 0.5 and s["by_family"]["stack"]["rate"] == 1.0
    assert s["by_family"]["place"]["low"] == pytest.approx(wilson_interval(1, 2)[0])
    assert s["by_level"]["L1"]["n"] == 3 and s["by_level"]["L2"]["successes"] == 0
    assert s["by_family_level"]["stack"] == {"L1": s["by_family"]["stack"]}
    assert "by_axis" not in s and "twins" not in s
    assert "Wilson" in s["methods"]["interval"] and "McNemar" in s["methods"]["p_value"]
    json.dumps(s, allow_nan=False)
    assert "by_level" not in summarize([_record(0, True)])


def test_summarize_pairs_each_perturbed_episode_with_its_clean_twin() -> None:
    clean = [_record(i, i != 3, id=f"c{i}") for i in range(4)]
    light = [_record(4 + i, i == 0, id=f"l{i}", axis="lighting", strength=5, twin=f"c{i}") for i in range(4)]
    camera = [_record(8, True, id="k0", axis="camera", strength=1, twin="c0"),
              _record(9, True, id="k1", axis="camera", strength=1, twin="missing")]
    s = summarize(clean + light + camera)
    assert list(s["by_axis"][CLEAN]) == ["0"] and s["by_axis"][CLEAN]["0"]["successes"] == 3
    assert s["by_axis"][CLEAN]["0"]["n"] == 4
    assert list(s["by_axis"]) == ["camera", "lighting", CLEAN]
    assert s["by_axis"]["lighting"]["5"]["successes"] == 1
    twins = s["twins"]["lighting"]["5"]
    # twins c0..c3 succeed, succeed, succeed, fail; the perturbed ones succeed, fail, fail, fail.
    assert (twins["both"], twins["first_only"], twins["second_only"], twins["neither"]) == (1, 2, 0, 1)
    assert twins["difference"] == -0.5 and twins["p_value"] == 0.5
    assert s["twins"]["camera"]["1"]["pairs"] == 1  # the record whose twin is not in the report is left out
    json.dumps(s, allow_nan=False)


def test_summarize_without_records_is_valid_json() -> None:
    s = summarize([])
    assert s["overall"] == {"successes": 0, "n": 0, "rate": None, "low": 0.0, "high": 1.0}
    assert s["by_family"] == {}
    assert not math.isnan(json.loads(json.dumps(s, allow_nan=False))["overall"]["high"])


def test_suite_records_name_the_clean_split_none_and_their_twin_by_index() -> None:
    """Suite episodes say axis ``none`` (strength 0) when clean and name their twin by its index."""
    records = [_record(0, True, axis="none", strength=0, twin=0), _record(1, False, axis="none", strength=0),
               _record(2, False, axis="camera", strength=3, twin=0), _record(3, False, axis="camera", strength=3,
                                                                              twin=1)]
    s = summarize(records)
    assert list(s["by_axis"]) == ["camera", CLEAN] and s["by_axis"][CLEAN]["0"]["n"] == 2
    assert [p["strength"] for p in s["curves"]["camera"]] == [0, 3]
    assert s["curves"]["camera"][0]["successes"] == 1  # its twins 0 and 1
    assert list(s["twins"]) == ["camera"]  # the clean episode naming itself is no pair
    assert (s["twins"]["camera"]["3"]["first_only"], s["twins"]["camera"]["3"]["neither"]) == (1, 1)
