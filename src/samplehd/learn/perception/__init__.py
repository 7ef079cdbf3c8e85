"""Perception: scene-camera RGB-D → object instances with class, colour, material, size and 3-D
position, as a CLEVR-layout scene annotation the executor and planner consume.

Two small networks:

- a U-Net on the image at half resolution labels every pixel background, robot, object, or
  *contact* (an object pixel touching another object's pixel); instances are the connected components
  of the object pixels, and contact pixels join the nearest instance;
- an attribute network looks at each instance's crop (RGB, mask, relative depth) plus its metric size
  from the depth (width, depth, height [m]) and appearance measures (highlights, fine texture) and names
  its class, colour, material and size, and its *kind* (class, shape variant and size together, which
  fixes the metric dimensions): the class and size it names are the averages of their own heads and of
  the kind head (its class marginal; its sizes within the class found).

The position is geometry, not learning: the instance's pixels are lifted to 3-D with the depth and the
camera's calibration; the centre of their ground-plane bounding box, on the table top, is the
object's ``3d_coords``. Table parts and relationships follow from positions as in the dataset.

Modules, one job each (LeRobot's split of a model):

- :mod:`~samplehd.learn.perception.configuration`: format version, labels, input sizes, thresholds,
  the vocabularies of the heads, and :class:`PerceptionConfig` (a model's ``config.json``);
- :mod:`~samplehd.learn.perception.geometry`: depth lifted to 3-D, instances, crops and measured features;
- :mod:`~samplehd.learn.perception.modeling`: the two networks;
- :mod:`~samplehd.learn.perception.inference`: :class:`Perception`, a trained model that perceives;
- :mod:`~samplehd.learn.perception.preparation`: training data from a dataset's scene images;
- :mod:`~samplehd.learn.perception.evaluation`: matching to the ground truth, test metrics;
- :mod:`~samplehd.learn.perception.training`: :func:`train_perception`.
"""

from __future__ import annotations

from samplehd.learn.perception.configuration import (
    FORMAT,
    PREPARED_FILE,
    PerceptionArchitecture,
    PerceptionConfig,
    PerceptionTraining,
    attribute_vocab,
    kind_vocab,
)
from samplehd.learn.perception.evaluation import evaluate_perception, perception_test_metrics, score_perception
from samplehd.learn.perception.geometry import backproject, height_map, instance_masks, join_stacked
from samplehd.learn.perception.inference import Perception, annotation_from_instances
from samplehd.learn.perception.preparation import size_templates
from samplehd.learn.perception.training import train_perception

__all__ = ["FORMAT", "PREPARED_FILE", "Perception", "PerceptionArchitecture", "PerceptionConfig", "PerceptionTraining",
           "annotation_from_instances", "attribute_vocab", "backproject",
           "evaluate_perception", "height_map", "instance_masks", "join_stacked", "kind_vocab",
           "perception_test_metrics", "score_perception", "size_templates", "train_perception"]
