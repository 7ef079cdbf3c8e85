"""samplehd.benchmark: what is measured on ``samplehd/Tabletop-v0``.

Evaluation of a policy on the seeded split or a frozen suite (:mod:`~samplehd.benchmark.evaluation`),
suites built with the oracle's proof (:mod:`~samplehd.benchmark.suite`), robustness variants beside their
clean twins (:mod:`~samplehd.benchmark.axes`, :mod:`~samplehd.benchmark.sensor`), episodes of a
generalisation level (:mod:`~samplehd.benchmark.levels`), the LeRobot adapters that run a checkpoint
(:mod:`~samplehd.benchmark.lerobot_policy`) and serve the split to ``lerobot-eval``
(:mod:`~samplehd.benchmark.lerobot_tabletop`). This floor sits above the environment (``envs``),
which knows nothing of splits, levels or reports.
"""
