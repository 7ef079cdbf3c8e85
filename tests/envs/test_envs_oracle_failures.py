"""Episodes that the closed-loop oracle once failed (of `samplehd evaluate`'s split, or candidates of a suite
build saved under data/), run as the benchmark runs them (:class:`samplehd.benchmark.evaluation.EpisodeRunner`,
default environment options but the catalogue): each must now be solved. Slow: a full episode each (10–20 s)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from samplehd.benchmark.evaluation import EpisodeRecord, EpisodeRunner, EvalConfig, split_episode

DATA = Path(__file__).parent / "data"


def _split_episode(catalogue: str, seed: int, k: int) -> EpisodeRecord:
    """Episode ``k`` of the default split of ``seed`` on ``catalogue``, driven by the oracle."""
    config = EvalConfig(policy="oracle", episodes=k + 1, seed=seed, env={"scene": {"catalogue": catalogue}})
    runner = EpisodeRunner(config)
    try:
        reset_seed, family = split_episode(k, config.families, seed)
        return runner.run((k, reset_seed, family))
    finally:
        runner.close()


def _saved_episode(name: str) -> EpisodeRecord:
    """A saved candidate of a suite build (scene and instruction as the build drew them), driven by the
    oracle as the build drives it."""
    saved = json.loads((DATA / name).read_text())
    slots = max(5, len(saved["scene"]["objects"]))  # the env's default 5 observation slots, or one per object
    env = {"obs_mode": "state", "scene": {"catalogue": saved["catalogue"], "max_objects": slots}}
    config = EvalConfig(policy="oracle", episodes=1, env=env)
    runner = EpisodeRunner(config)
    try:
        return runner.run((0, saved["seed"], saved["instruction"]["family"]),
                          options={"scene": saved["scene"], "instruction": saved["instruction"]})
    finally:
        runner.close()


@pytest.mark.slow
def test_oracle_stacks_a_mug_on_a_baking_tray_without_dropping_it_through_the_floor() -> None:
    """core, shop-vrb stack L1, candidate 0: the mug's release height stopped where the bounding box of its
    visual geoms (MuJoCo's, in each piece's principal-axes frame: 8 mm below the collision hulls) met the
    table, 4.5 mm above the tray's 2 mm floor; released 10.5 mm above the floor, it fell through it onto
    the table ("object 2 is not above object 0"). The height now stops where the hulls meet the table."""
    record = _saved_episode("core_shop_vrb_stack_l1_0.json")
    assert record.instruction == "Put the mug on top of the baking tray."
    assert record.success, (record.check_reason, record.gave_up)


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


@pytest.mark.slow
@pytest.mark.parametrize(("name", "instruction"), [
    ("core_procedural_pick_up_l2_9.json", "Grab the plate and hold it up."),
    ("core_procedural_place_l1_2.json", "Slide the plate and the fork to the left half of the table."),
    ("core_procedural_stack_l3_10.json", "Stack the plate onto the baking tray."),
    ("core_procedural_stack_three_l2_3.json",
     "Build a tower with the large plate at the bottom, the small plate in the middle and the thermos on top."),
])
def test_oracle_grasps_a_soup_plate_by_its_sloped_brim(name: str, instruction: str) -> None:
    """core, procedural: the small soup plate's brim rises 20 mm outwards over its top 5.6 mm. The rim
    grasp's pads stood around the site's nominal 2.4 mm wall; reaching 4 mm below the top, the inner pad
    met the brim's upper face about 9 mm before the outer pad met the lip, pushed and tilted the plate,
    and the grasp assist (both pads touching) never welded: ``grasp_missed`` three times, or
    ``approach_blocked`` by the tilted plate. The oracle now centres the pads on what they pinch, so
    both touch in the same step, and it is welded without moving."""
    record = _saved_episode(name)
    assert record.instruction == instruction
    assert record.success, (record.check_reason, record.gave_up)
    assert record.replans == 0


@pytest.mark.slow
def test_oracle_sets_scissors_on_a_board_without_shooting_them_through_it() -> None:
    """core, shop-vrb stack L3, candidate 3: the weld held the scissors 6 mm above the 13 mm board as
    planned, but the opening command released the weld while the pads still squeezed the scissors'
    tapered body: shot out of the pads, they fell 27 mm in one control step, partly through the board
    ("object 2 is not above object 1"). The oracle now eases the pads off (the weld still on) first."""
    record = _saved_episode("core_shop_vrb_stack_l3_3.json")
    assert record.instruction == "Stack the scissors onto the chopping board."
    assert record.success, (record.check_reason, record.gave_up)


@pytest.mark.slow
def test_oracle_places_a_baking_tray_behind_a_box_turned_half_round() -> None:
    """core, procedural place_relative L4, candidate 1: held by its rim, the baking tray found no release
    pose behind the food box: at every spot the arm folded into itself (forearm against upper arm and
    table; ``no_release_path``). The oracle now also tries each spot with the tray turned half round
    (its footprint is symmetric about its origin), which puts the grasp on the far side."""
    record = _saved_episode("core_procedural_place_relative_l4_1.json")
    assert record.instruction == "Position the baking tray behind the food box."
    assert record.success, (record.check_reason, record.gave_up)


@pytest.mark.slow
def test_oracle_sets_scissors_on_a_plate_without_dragging_them_through_it() -> None:
    """core, shop-vrb stack_three L1, candidate 17: the scissors (5.6 g) were eased 7 mm over the plate,
    then the fingers were commanded open at once; the servo snapped the pads 10 mm apart within a few
    milliseconds, and the pad resting on the scissors dragged them sideways and down at 1.3 m/s, 13 mm
    deep, through the plate's 3 mm floor ("object 2 is not above object 4"). The oracle now opens just
    past the weld's release for one step first: the scissors drop clear of the pads onto the plate."""
    record = _saved_episode("core_shop_vrb_stack_three_l1_17.json")
    assert record.instruction == "Stack the plate on the chopping board and then the scissors on the plate."
    assert record.success, (record.check_reason, record.gave_up)
