"""samplehd.benchmark: what is measured on ``samplehd/Tabletop-v0``.

Evaluation of a policy on the seeded split (:mod:`~samplehd.benchmark.evaluation`), episodes of a
generalisation level (:mod:`~samplehd.benchmark.levels`), the LeRobot adapters that run a checkpoint
(:mod:`~samplehd.benchmark.lerobot_policy`) and serve the split to ``lerobot-eval``
(:mod:`~samplehd.benchmark.lerobot_tabletop`). This floor sits above the environment (``envs``),
which knows nothing of splits, levels or reports.
"""
