"""The learning side: an instruction parser, a perception model, a neuro-symbolic closed-loop policy
and a visuomotor behaviour-cloning policy, trained on samplehd datasets with PyTorch (the optional
``learn`` extra). Modules import torch only inside functions, so ``import samplehd.learn`` works
without it.

- :mod:`samplehd.learn.parser`: instruction → flat program and CLEVR node list (``samplehd train parser``)
- :mod:`samplehd.learn.perception`: RGB-D → scene annotation (``samplehd train perception``)
- :mod:`samplehd.learn.neurosymbolic`: parse, perceive, execute, plan, act (``evaluate --policy neurosymbolic``)
- :mod:`samplehd.learn.bc`: images + tokens + state → steering chunks (``samplehd train policy``,
  ``evaluate --policy bc``)
- :mod:`samplehd.learn.training`: checkpoints, resume, progress, determinism
"""

__all__ = ["bc", "data", "neurosymbolic", "parser", "perception", "training"]
