"""Rendering recorded states: every frame written into its slot of the streams equals a render of that state."""

import mujoco
import numpy as np
import pytest

from samplehd.render.renderer import MODALITIES, SceneRenderer
from samplehd.render.states import render_states, set_state

pytestmark = pytest.mark.render


def test_render_states_equals_one_render_per_state(world):
    model, data = world
    qpos = np.stack([data.qpos + d for d in (0.0, 0.3, -0.4)])
    qpos[:, 6:] = data.qpos[6:]  # move the arm only
    frames = {"qpos": qpos, "qvel": np.zeros((3, model.nv))}
    got = render_states(model, frames, ("operator", "wrist"), MODALITIES, 64, 48, "fast", indices=[2, 0])
    d = mujoco.MjData(model)
    with SceneRenderer(model, 64, 48, "fast") as r:
        for i, k in enumerate((2, 0)):
            set_state(model, d, qpos[k], frames["qvel"][k])
            for cam in ("operator", "wrist"):
                for m, want in r.render(d, cam, MODALITIES).items():
                    assert got[cam][m].shape == (2, *want.shape) and got[cam][m].dtype == want.dtype
                    np.testing.assert_array_equal(got[cam][m][i], want, err_msg=f"{cam} {m} frame {k}")
    assert not np.array_equal(got["operator"]["rgb"][0], got["operator"]["rgb"][1])
    empty = render_states(model, frames, ("operator",), ("depth",), 64, 48, "fast", indices=[])
    assert empty["operator"]["depth"].shape == (0, 48, 64) and empty["operator"]["depth"].dtype == np.float32
