"""Task families and the success checker shared by path generation, the environment and evaluation."""

from samplehd.tasks.checker import CheckerConfig, CheckResult, check_success
from samplehd.tasks.task import FAMILIES, Task, parse_task

__all__ = ["FAMILIES", "CheckResult", "CheckerConfig", "Task", "check_success", "parse_task"]
