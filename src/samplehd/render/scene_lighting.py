"""How a compiled model's lights differ from the kitchen's own, carried in the model for every renderer.

The GL presets draw the model's own lights, so a changed :class:`samplehd.scene.world.Lighting` reaches them
through the lights themselves. The photo preset lights the room with its own emitters
(:func:`samplehd.render.photo.look.lights`); it reads the same change from a custom numeric field of the
model, :data:`LIGHTING_NUMERIC`, that the world builder writes whenever the lighting is not the default:
``[intensity, turn, red, green, blue]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

__all__ = ["LIGHTING_NUMERIC", "SceneLighting", "model_lighting", "write_lighting"]

LIGHTING_NUMERIC = "samplehd_lighting"


@dataclass(frozen=True)
class SceneLighting:
    """The change of a scene's lights (the default changes nothing).

    Attributes:
        intensity: factor on every light [1].
        turn: the key light turned about the vertical through the table centre [deg, counter-clockwise
            seen from above].
        tint: factor per colour channel (red, green, blue) on every light [1].
    """

    intensity: float = 1.0
    turn: float = 0.0
    tint: tuple[float, float, float] = (1.0, 1.0, 1.0)


def write_lighting(spec: mujoco.MjSpec, lighting: SceneLighting) -> None:
    """Record ``lighting`` in ``spec`` (a custom numeric field) for renderers that do not draw its lights."""
    spec.add_numeric(name=LIGHTING_NUMERIC, data=[float(lighting.intensity), float(lighting.turn),
                                                  *(float(c) for c in lighting.tint)])


def model_lighting(model: mujoco.MjModel) -> SceneLighting:
    """The lighting change recorded in ``model`` (the default when it has none)."""
    try:
        data = model.numeric(LIGHTING_NUMERIC).data
    except KeyError:
        return SceneLighting()
    return SceneLighting(float(data[0]), float(data[1]), (float(data[2]), float(data[3]), float(data[4])))
