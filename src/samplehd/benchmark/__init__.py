"""samplehd.benchmark: what is measured on ``samplehd/Tabletop-v0``, and how it is reported.

Evaluation of a policy on the seeded split or a frozen suite (:mod:`~samplehd.benchmark.evaluation`),
suites built with the oracle's proof (:mod:`~samplehd.benchmark.suite`), robustness variants beside their
clean twins (:mod:`~samplehd.benchmark.axes`, :mod:`~samplehd.benchmark.sensor`), episodes of a
generalisation level (:mod:`~samplehd.benchmark.levels`), the LeRobot adapters that run a checkpoint
(:mod:`~samplehd.benchmark.lerobot_policy`) and serve the split to ``lerobot-eval``
(:mod:`~samplehd.benchmark.lerobot_tabletop`), and what turns evaluation records into figures a paper
can cite: statistics with their intervals (:mod:`~samplehd.benchmark.statistics`), paired comparisons
of two reports (:mod:`~samplehd.benchmark.compare`), robustness curves and tables. This floor sits
above the environment (``envs``), which knows nothing of splits, levels or reports.
"""
