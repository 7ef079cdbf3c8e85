"""Chance level of a language-blind pick on a suite's pick_up episodes: a policy that ignores the
instruction and lifts one of the objects it can grasp, drawn uniformly, succeeds with probability
1 / (objects the planner finds a grasp for from the start state) per episode. Prints the expected
number of chance successes with its share, per level.

usage: python scripts/baselines/pick_chance.py SUITE   (a shipped suite's name or a suite file; the
       Python that has samplehd)
"""

from __future__ import annotations

import sys
from collections import defaultdict

from samplehd.envs.suite_file import read_suite
from samplehd.motion.execute import initial_state, scene_facts
from samplehd.robot.controller import ControlConfig
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.world.grasps import graspable_in_scene


def main(name: str) -> int:
    suite = read_suite(name)
    chance: dict[str, list[float]] = defaultdict(list)
    for ep in suite.episodes:
        if ep.family != "pick_up" or ep.axis != "none":
            continue
        spec = SceneSpec.from_dict(ep.scene)
        model, data = compile_scene(spec)
        initial_state(model, data, ControlConfig())
        graspable = sum(graspable_in_scene(model, data, scene_facts(spec)))
        chance[ep.level].append(1.0 / max(1, graspable))
    print(f"suite {suite.name} ({suite.content_hash}): pick_up chance of a blind pick")
    for level, values in sorted(chance.items()):
        share = 100 * sum(values) / len(values)
        print(f"  {level}: {sum(values):.2f} expected successes of {len(values)} ({share:.1f} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
