"""The worker backends' Feed: units put while results come in, run in one pool, and WAIT."""

from __future__ import annotations

import pytest

from samplehd.workers import WAIT, Backend, Feed


def _chains(backend: Backend, starts: list[int]) -> list[tuple[int, int]]:
    """Chains counting down to 1: unit -n gives n (abs), and a result n > 1 asks for -(n - 1)."""
    feed = Feed()
    for n in starts:
        feed.put(-n)
    seen = []
    for unit, result in feed.run(backend, abs):
        seen.append((unit, result))
        if result > 1:
            feed.put(-(result - 1))
    return seen


@pytest.mark.parametrize("workers", [1, 2])
def test_feed_runs_units_put_while_it_runs(workers: int) -> None:
    seen = _chains(Backend(workers=workers), [3, 5])
    assert sorted(seen) == sorted([(-n, n) for n in (3, 2, 1)] + [(-n, n) for n in (5, 4, 3, 2, 1)])


def test_an_empty_feed_runs_nothing() -> None:
    assert list(Feed().run(Backend(workers=2), abs)) == []


def test_the_lowest_priority_starts_first_then_the_earliest_put() -> None:
    feed = Feed()
    for unit, priority in ((1, 0), (2, -1), (3, 0), (4, -2), (5, -1)):
        feed.put(unit, priority=priority)
    assert [unit for unit, _ in feed.run(Backend(), abs)] == [4, 2, 5, 1, 3]


@pytest.mark.parametrize("workers", [1, 2])
def test_waiting_while_nothing_runs_is_refused(workers: int) -> None:
    with pytest.raises(RuntimeError, match="waits for a result while no unit runs"):
        list(Backend(workers=workers).map(abs, iter([-1, WAIT] if workers == 1 else [WAIT])))
