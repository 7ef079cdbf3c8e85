"""One suite episode beside its variant at strength 5 on every robustness axis (scene camera), as a
contact sheet: clean twin on the left, the variant on the right, the instruction under each label.

    python scripts/suite_axes_sheet.py SUITE OUT.png [EPISODE]
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import sys

from PIL import Image

from samplehd.benchmark.axes import AXES, perturb
from samplehd.benchmark.sensor import corrupt_observation, sensor_rng
from samplehd.envs.suite_file import SuiteEpisode, read_suite
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import SceneError
from samplehd.render.contact_sheet import contact_sheet


def _variant(twin: dict, axis: str, attempts: int = 4) -> dict:
    """The first variant at strength 5 that can be made (a distractor may find no free spot)."""
    for attempt in range(attempts - 1):
        try:
            return perturb(twin, axis, 5, seed=0, attempt=attempt)
        except SceneError:
            pass
    return perturb(twin, axis, 5, seed=0, attempt=attempts - 1)


def main(suite_name: str, out: str, index: int = 0) -> None:
    suite = read_suite(suite_name)
    twin = suite.episode(index).to_dict()
    env = TabletopEnv(render_mode="rgb_array", width=480, height=360)
    images, labels = [], []
    try:
        for axis in AXES:
            for ep, name in ((twin, f"{axis}: clean twin"), (_variant(twin, axis), f"{axis}: strength 5")):
                env.reset(options=SuiteEpisode.from_dict({"id": 0, **ep}).reset_options())
                frame = {"scene_rgb": env.render()}  # the sensor axis corrupts what the policy sees
                images.append(corrupt_observation(frame, ep.get("sensor"), sensor_rng(ep["reset_seed"]))["scene_rgb"])
                labels.append(f"{name} | {ep['instruction']}")
    finally:
        env.close()
    Image.fromarray(contact_sheet(images, 2, labels)).save(out, optimize=True)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 0)
