"""Where a measurement ran: the commit measured and the machine, for the header of a recorded run
(``samplehd bench --report``, the baselines' tables)."""

from __future__ import annotations

import os
import platform
import subprocess
from pathlib import Path

from samplehd.errors import RenderError
from samplehd.render.renderer import gl_device
from samplehd.version import __version__

__all__ = ["machine_description", "measured_commit"]


def measured_commit() -> str:
    """The commit measured (with ``+changes`` when the tree differs from it), or the package version."""
    here = Path(__file__).resolve().parent
    try:
        sha = subprocess.run(["git", "rev-parse", "--short=10", "HEAD"], cwd=here, capture_output=True, text=True,
                             timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=here,
                               capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return f"samplehd {__version__} (not a git checkout)"
    return f"{sha}{' +changes' if dirty else ''} (samplehd {__version__})"


def machine_description() -> str:
    """The machine a measurement ran on: processor, logical cores, memory, system, Python, and the GL
    backend with the device that renders."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(Path("/proc/meminfo").read_text().split("MemTotal:")[1].split()[0])
        mem = f", {kb / 2**20:.0f} GiB"
    except (OSError, IndexError, ValueError):
        pass
    gl = os.environ.get("MUJOCO_GL", "")
    try:
        device = f" ({gl_device()})"
    except RenderError:
        device = " (no GL context)"
    return (f"{cpu}, {os.cpu_count()} logical cores{mem}, {platform.system()} {platform.release()}, "
            f"Python {platform.python_version()}, MuJoCo GL backend {gl or 'default'}{device}")
