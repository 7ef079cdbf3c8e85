"""Tasks: the one Task type, the registry of task families (each declared in its own module of
:mod:`samplehd.tasks.families`) and the success checker shared by path generation, the environment
and evaluation."""

import samplehd.tasks.families  # noqa: F401  (registers the built-in families)
