"""Recording: the step wrapper that records one frame per control step, the episode record, and the
ground-truth path of one instruction (:func:`samplehd.record.paths.plan_and_execute`)."""
