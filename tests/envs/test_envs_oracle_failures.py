"""Episodes of `samplehd evaluate`'s split that the closed-loop oracle once failed, run as the benchmark
runs them (:class:`samplehd.benchmark.evaluation.EpisodeRunner`, default environment options but the
catalogue): each must now be solved. Slow: a fresh scene and a full episode each (10–20 s)."""

from __future__ import annotations

import pytest

from samplehd.benchmark.evaluation import EpisodeRecord, EpisodeRunner, EvalConfig, split_episode


def _split_episode(catalogue: str, seed: int, k: int) -> EpisodeRecord:
    """Episode ``k`` of the default split of ``seed`` on ``catalogue``, driven by the oracle."""
    config = EvalConfig(policy="oracle", episodes=k + 1, seed=seed, env={"scene": {"catalogue": catalogue}})
    runner = EpisodeRunner(config)
    try:
        reset_seed, family = split_episode(k, config.families, seed)
        return runner.run((k, reset_seed, family))
    finally:
        runner.close()


@pytest.mark.slow
def test_oracle_grasps_a_thermos_by_its_handle_without_a_contact_force_stop() -> None:
    """Procedural seed 8080, k = 5: the fingers closed on the thermos's handle ring with a squeeze
    ramp; the second pad met the ring 1.2 mm deep (954 N against the 150 N limit). The oracle now
    stops closing when both pads touch, as the dataset's paths do."""
    record = _split_episode("procedural", 8080, 5)
    assert record.instruction == "Set the thermos to the left of the plastic chopping board."
    assert record.safety_events == ()
    assert record.success, (record.check_reason, record.gave_up)


@pytest.mark.slow
def test_oracle_places_a_fork_on_a_board() -> None:
    """shop-vrb seed 97531, k = 20: squeezed, the fork turned in the fingers and was released lying
    partly off the board's top; with the grip that stops at the touch it lands on the board."""
    record = _split_episode("shop-vrb", 97531, 20)
    assert record.instruction == "Place the fork on top of the chopping board."
    assert record.success, (record.check_reason, record.gave_up)
    assert record.replans == 0


@pytest.mark.slow
def test_oracle_sets_scissors_down_on_a_board() -> None:
    """shop-vrb seed 97531, k = 2: squeezed, the fingers closed to 2.3 mm on the scissors' 10 mm body
    (the scissors turned between the pads) and carried them low in the hand; at the release the
    opened pads touched the board on both sides, the grasp assist welded the board and the arm lifted
    it on the way home. With the grip that stops at the touch (14.5 mm) they land on the board."""
    record = _split_episode("shop-vrb", 97531, 2)
    assert record.instruction == "Set the scissors down on the chopping board."
    assert record.success, (record.check_reason, record.gave_up)
    assert record.disturbed == ()
