"""Fixed numbers of the search for a free spot to put an object down on the table.

The ground-truth planner (:func:`samplehd.motion.planner.destination_candidates`) samples spots with
them, and the language stage's room test (:mod:`samplehd.world.free_spot`) predicts that search
with the same numbers; this module imports nothing heavy, so the language stage stays free of MuJoCo.
"""

from __future__ import annotations

import math

# Turns sampled about the vertical, relative to the object's yaw (no turn twice as often) [rad].
SPOT_TURNS = (0.0, 0.0, math.pi / 4, -math.pi / 4, math.pi / 2, -math.pi / 2)
SPOT_TABLE_EDGE = 0.03  # footprint at least this far inside the table's edges [m]
SPOT_WORKSPACE_SLACK = 0.05  # place_relative: origin at most this far outside the workspace [m]
BESIDE_NEED = 0.02  # place_relative: origin past the reference's by relation_gap plus this [m]
# place_relative: half the samples (distance past the reference, lateral offset) near, half far [m]
BESIDE_NEAR = (0.15, 0.08)
BESIDE_FAR = (0.3, 0.16)
# A free spot's score (lower is better): minus the distance to the nearest other object capped at
# SPOT_ROOM_CAP, plus SPOT_REACH_WEIGHT times the origin's distance from SPOT_COMFORT_REACH from the
# robot base, plus SPOT_TURN_WEIGHT per radian of turn, plus SPOT_FAR_PENALTY per metre a
# place_relative sample lies beyond the near box.
SPOT_ROOM_CAP = 0.25  # [m]
SPOT_COMFORT_REACH = 0.5  # [m]
SPOT_REACH_WEIGHT = 0.3
SPOT_TURN_WEIGHT = 0.05  # [1/rad]
SPOT_FAR_PENALTY = 2.0  # [1/m]
SPOT_SHORTLIST = 12  # free samples kept, best first
SPOT_OPTIONS = 6  # of which this many are tried
# Where none of those can be reached and released (the wrist against a tall neighbour, the arm folded
# near its base), the planner samples again, this many times as many, and tries the best SPOT_SECOND_LOOK.
SPOT_SECOND_SAMPLES = 3
SPOT_SECOND_LOOK = 24
# With more objects still to come to the same table part, spots that leave each of them a free spot on a
# grid of this pitch [m] (filled greedily, in turn) and stay GRASP_ROOM clear of the footprints of those
# still to be picked up [m] are tried first.
ROOM_GRID_STEP = 0.02
GRASP_ROOM = 0.08
