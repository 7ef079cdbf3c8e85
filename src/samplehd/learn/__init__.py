"""The learning side: an instruction parser, a perception model, a neuro-symbolic closed-loop policy
and a visuomotor behaviour-cloning policy, trained on samplehd datasets with PyTorch (the optional
``learn`` extra). The model modules import torch at module level through
:mod:`samplehd.learn.training` (without it: one line naming the extra); :mod:`samplehd.learn.data`
and :mod:`samplehd.learn.options` need no torch.

- :mod:`samplehd.learn.parser`: instruction → flat program and CLEVR node list (``samplehd train parser``), a
  package of one module per job: configuration, processing, modeling, inference, evaluation, training
- :mod:`samplehd.learn.perception`: RGB-D → scene annotation (``samplehd train perception``), a package of one
  module per job: configuration, geometry, modeling, inference, preparation, evaluation, training
- :mod:`samplehd.learn.neurosymbolic`: parse, perceive, execute, plan, act (``evaluate --policy neurosymbolic``)
- :mod:`samplehd.learn.policy`: images + tokens + state → steering chunks or waypoints (``samplehd train
  policy``, ``evaluate --policy bc``), a package of one module per job: configuration (no torch),
  processing, modeling, inference, preparation, training
- :mod:`samplehd.learn.keypose`: a top-down view of the scene camera's RGB-D + tokens → where to grasp and
  where the object goes (``samplehd train policy --action keypose``, ``evaluate --policy bc``), a package
  of one module per job: configuration (no torch), processing, modeling, follower, inference,
  preparation, training

Shared by the models: :mod:`samplehd.learn.configuration` (the header of every model config, no torch),
:mod:`samplehd.learn.data` (dataset splits), :mod:`samplehd.learn.demos` (episodes collected in the
environment), :mod:`samplehd.learn.actions` (steering and waypoint labels and followers) and
:mod:`samplehd.learn.topdown` (the top-down grid of an RGB-D image).

- :mod:`samplehd.learn.training`: torch, checkpoints, resume, progress, determinism
- :mod:`samplehd.learn.options`: the environment a trained policy needs (no torch)
"""

__all__ = ["actions", "configuration", "data", "demos", "keypose", "neurosymbolic", "options", "parser", "perception",
           "policy", "topdown", "training"]
