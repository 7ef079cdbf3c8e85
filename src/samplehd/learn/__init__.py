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
- :mod:`samplehd.learn.bc`: images + tokens + state → steering chunks (``samplehd train policy``,
  ``evaluate --policy bc``)
- :mod:`samplehd.learn.training`: torch, checkpoints, resume, progress, determinism
- :mod:`samplehd.learn.policy_configuration`: :class:`PolicyConfig`, the BC policy's ``config.json`` (no torch)
- :mod:`samplehd.learn.options`: the environment a trained policy needs (no torch)
"""

__all__ = ["bc", "data", "neurosymbolic", "options", "parser", "perception", "policy_configuration", "training"]
