"""Export a whole scene (table, robot, objects) as MJCF with keyframes, for MuJoCo's own tools.

The file loads with ``mujoco.MjModel.from_xml_path`` and opens in ``python -m mujoco.viewer
--mjcf FILE`` (textures go to PNGs and meshes to ``.msh`` files in ``<stem>_assets/``). Keyframes:

- ``home``: the arm at home holding still, gripper open, objects where the scene puts them (for a
  dataset episode: its first recorded state);
- ``final`` (dataset episodes only): the episode's last recorded state.

Actuators (``ctrl`` layout): 6 ``robot_<joint>_position`` actuators are *integrated-velocity*
position servos: ``ctrl`` is the velocity [rad/s] of the joint's position target and MuJoCo
integrates it into the target, which lives in ``data.act`` [rad]. A keyframe therefore carries the
targets in ``act`` (equal to the arm's joint angles) and 0 in their ``ctrl``, so the arm holds its
pose; setting such a ``ctrl`` to 0.1 moves the target (and the joint) at 0.1 rad/s until the joint
limit, not to 0.1 rad. 6 ``robot_<joint>_velocity`` actuators are velocity servos fed the same
target velocity (0 holds). ``robot_gripper`` is a plain position servo on the finger opening width
[m], 0 (closed) … 0.085 (open). The arm links carry gravity compensation.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from samplehd.dataset.reader import DatasetReader
from samplehd.errors import ConfigError, DatasetError
from samplehd.motion.execute import initial_state
from samplehd.robot.constants import GRIPPER_ACTUATOR, GRIPPER_STROKE
from samplehd.robot.controller import ControlConfig
from samplehd.scene.mjcf import export_mjcf
from samplehd.scene.spec import SceneSpec, compile_scene
from samplehd.scene.world import PlacedObject, build_world

__all__ = ["scene_mjcf_from_dataset", "scene_mjcf_from_file", "write_scene_mjcf"]


def _spec_with_objects(scene: Any) -> mujoco.MjSpec:
    placed = [PlacedObject(o.instance, tuple(o.pos), tuple(o.quat)) for o in scene.objects]
    return build_world(placed, scene.world_config())


def _home_state(scene: Any) -> dict[str, np.ndarray]:
    model, data = compile_scene(scene)
    initial_state(model, data, ControlConfig())
    return {"qpos": data.qpos.copy(), "act": data.act.copy(), "gripper": GRIPPER_STROKE}


def write_scene_mjcf(scene: Any, out: str | Path, keyframes: dict[str, dict[str, np.ndarray]] | None = None) -> Path:
    """Write ``scene`` (a :class:`~samplehd.scene.spec.SceneSpec`) with keyframes to ``out`` (.xml).

    Args:
        scene: the scene.
        out: the MJCF file (``.xml``).
        keyframes: name → ``{qpos, act, gripper}`` (gripper: opening width [m]; ``qvel`` and the arm's
            ``ctrl`` are 0); default: ``home`` from the scene.

    Raises:
        ConfigError: ``out`` does not end in .xml or a keyframe does not fit the model.
    """
    out = Path(out)
    if out.suffix.lower() != ".xml":
        raise ConfigError(f"out={out}: the MJCF file must end in .xml", field="out")
    spec = _spec_with_objects(scene)
    model = spec.copy().compile()
    keyframes = keyframes or {"home": _home_state(scene)}
    for name, state in keyframes.items():
        for field, n in (("qpos", model.nq), ("act", model.na)):
            if len(state[field]) != n:
                raise ConfigError(f"keyframe {name}: {field} has {len(state[field])} values; the model needs {n}")
        ctrl = np.zeros(model.nu)
        ctrl[model.actuator(GRIPPER_ACTUATOR).id] = float(state["gripper"])
        spec.add_key(name=name, time=0.0, qpos=[float(v) for v in state["qpos"]], qvel=[0.0] * model.nv,
                     act=[float(v) for v in state["act"]], ctrl=[float(v) for v in ctrl])
    return export_mjcf(spec, out)


def scene_mjcf_from_file(path: str | Path, out: str | Path) -> Path:
    """Export the scene of a scene file: ``scenes/SHD_*.json`` of a dataset, an entry of ``scenes.json``
    or a bare SceneSpec dict (the ``spec`` field)."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except OSError as exc:
        raise ConfigError(f"scene={path}: cannot read ({exc.strerror})", field="scene") from None
    except json.JSONDecodeError as exc:
        raise ConfigError(f"scene={path}: invalid JSON at line {exc.lineno}: {exc.msg}", field="scene") from None
    if isinstance(doc, dict) and "scenes" in doc and isinstance(doc["scenes"], list):
        raise ConfigError(f"scene={path}: holds {len(doc['scenes'])} scenes; give one scene file "
                          "(scenes/SHD_<split>_<index>.json) or `dataset` DIR `episode` I", field="scene")
    spec_dict = doc.get("spec", doc) if isinstance(doc, dict) else None
    if not isinstance(spec_dict, dict) or "objects" not in spec_dict or "camera" not in spec_dict:
        raise ConfigError(f"scene={path}: field 'spec' (or a SceneSpec with 'objects' and 'camera') missing; "
                          "valid: a scene file of a samplehd dataset", field="scene")
    try:
        scene = SceneSpec.from_dict(spec_dict)
    except Exception as exc:  # the spec parser reports many kinds of malformed values
        raise ConfigError(f"scene={path}: {exc}", field="scene") from None
    return write_scene_mjcf(scene, out)


def scene_mjcf_from_dataset(root: str | Path, episode: int, out: str | Path) -> Path:
    """Export the scene of dataset episode ``episode`` with keyframes ``home`` (its first recorded
    state) and ``final`` (its last)."""
    reader = DatasetReader(root)
    if not 0 <= episode < len(reader):
        raise DatasetError(f"episode={episode}: {root} has episodes 0..{len(reader) - 1}", field="episode")
    scene_index = reader.episodes[episode].scene_index
    scene = SceneSpec.from_dict(reader.scene(scene_index)["spec"])
    f = reader.frames(episode, ["qpos", "act", "gripper_opening", "gripper_command", "grasped_object"])
    keys = {}
    for name, t in (("home", 0), ("final", len(f["qpos"]) - 1)):
        # The gripper servo holds the recorded opening; a grasp keeps its commanded width (it squeezes).
        width = float(f["gripper_opening"][t])
        if int(f["grasped_object"][t]) >= 0:
            width = (float(f["gripper_command"][t]) + 1.0) / 2.0 * GRIPPER_STROKE  # +1 open, -1 closed
        keys[name] = {"qpos": f["qpos"][t], "act": f["act"][t], "gripper": width}
    return write_scene_mjcf(scene, out, keys)
