"""Where a dataset generation's CPU time goes, stage by stage.

Runs ``samplehd generate ARGS`` in this process (give ``--workers 1``: the work units then run here)
and samples the running Python stack every ``--interval`` CPU milliseconds of the process (a
``SIGPROF`` timer, so a busy machine does not move the figures). Each sample weighs the process's CPU
time since the previous one (a long call into C delivers its signal when it returns, to its caller)
and is put in one stage:

- inside a scene unit: ``scene images`` (the render package) or ``scene sampling and settling``;
- inside an episode unit, by the innermost frame of these modules: ``IK`` (robot.kinematics),
  ``grasp rule`` (motion.assist), ``execution`` (robot.controller, physics: MuJoCo's steps),
  ``recording`` (record.recorder, record.episode, dataset.container); ``checker`` wherever
  tasks.checker is on the stack (its own physics included); ``model compile`` (the unit's scene
  model, ``compile_scene_with_assist``); ``planning`` otherwise (motion, world,
  the planner's collision queries);
- ``instruction generation`` (the language package outside the units);
- ``other``: start-up, imports, the coordinator, finalising.

A second, cross-cutting figure counts the samples with a frame of the fixed-order arithmetic
(``fixedmath``, ``fixedkernels``) anywhere on the stack. The script prints a Markdown table (CPU
seconds and share of the sampled time) and the 25 innermost functions; with ``--every S`` it also
writes the table so far every S CPU seconds into ``--partial FILE``.

Usage::

    python scripts/generate_stages.py -- --preset sample-hd --scenes 30 --render none --seed 0 \
        --workers 1 --quiet --out DIR
"""

from __future__ import annotations

import argparse
import collections
import os
import resource
import signal
import sys
import time
from pathlib import Path
from types import FrameType

STAGES = ("scene sampling and settling", "scene images", "instruction generation", "model compile", "planning", "IK",
          "execution", "checker", "grasp rule", "recording", "other")
_INNER = (("/robot/kinematics.py", "IK"), ("/motion/assist.py", "grasp rule"), ("/robot/controller.py", "execution"),
          ("/samplehd/physics.py", "execution"), ("/record/recorder.py", "recording"),
          ("/record/episode.py", "recording"), ("/dataset/container.py", "recording"))


def classify(frames: list[tuple[str, str]]) -> tuple[str, bool]:
    """The stage of one stack (innermost frame first) and whether fixed-order arithmetic is on it."""
    fixed = any(f.endswith(("/samplehd/fixedmath.py", "/samplehd/fixedkernels.py")) for f, _ in frames)
    for i, (path, func) in enumerate(frames):
        if path.endswith("/dataset/work.py") and func == "run_scene_unit":
            inner = frames[:i]
            return ("scene images" if any("/samplehd/render/" in f for f, _ in inner)
                    else "scene sampling and settling"), fixed
        if path.endswith("/dataset/work.py") and func == "run_episode_unit":
            if any(p.endswith("/tasks/checker.py") for p, _ in frames[:i]):  # its own physics included
                return "checker", fixed
            if any(fn == "compile_scene_with_assist" for _, fn in frames[:i]):
                return "model compile", fixed
            for p, _ in frames[:i]:
                for key, stage in _INNER:
                    if key in p:
                        return stage, fixed
            return "planning", fixed
        if "/samplehd/language/" in path:
            return "instruction generation", fixed
    return "other", fixed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--interval", type=float, default=2.0, help="CPU milliseconds between samples")
    parser.add_argument("--every", type=float, default=0.0, help="write the table so far every this many CPU s")
    parser.add_argument("--partial", default="stages-so-far.md", help="where --every writes it")
    parser.add_argument("generate_args", nargs=argparse.REMAINDER, help="-- then the arguments of samplehd generate")
    args = parser.parse_args(argv)
    gen_args = [a for a in args.generate_args if a != "--"]
    counts: collections.Counter[str] = collections.Counter()  # CPU seconds per stage
    leaves: collections.Counter[str] = collections.Counter()
    fixed_count = [0.0]
    last = [time.process_time()]

    def on_sample(signum: int, frame: FrameType | None) -> None:
        now = time.process_time()
        weight, last[0] = now - last[0], now
        frames: list[tuple[str, str]] = []
        f = frame
        while f is not None:
            frames.append((f.f_code.co_filename, f.f_code.co_name))
            f = f.f_back
        stage, fixed = classify(frames)
        counts[stage] += weight
        fixed_count[0] += weight * fixed
        if frames:
            path, func = frames[0]
            leaves[f"{path.rsplit('/samplehd/', 1)[-1]}:{func}"] += weight

    from samplehd.cli import main as samplehd_main

    t0, c0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF)

    def write_table(note: str) -> str:
        c1 = resource.getrusage(resource.RUSAGE_SELF)
        cpu = (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)
        total = sum(counts.values()) or 1.0
        lines = [f"samplehd generate {' '.join(gen_args)}{note}: {cpu:.1f} CPU s, {time.perf_counter() - t0:.1f} s "
                 f"wall, {total:.1f} CPU s sampled, load average {os.getloadavg()[0]:.1f}",
                 "| stage | CPU s | share |", "|---|---|---|"]
        lines += [f"| {stage} | {counts[stage]:.1f} | {counts[stage] / total:.1%} |" for stage in STAGES]
        lines.append(f"| (fixed-order arithmetic, across stages) | {fixed_count[0]:.1f} | "
                     f"{fixed_count[0] / total:.1%} |")
        lines.append("\ninnermost functions:")
        lines += [f"{n / total:6.1%}  {name}" for name, n in leaves.most_common(25)]
        return "\n".join(lines) + "\n"

    if args.every:  # a table so far every ``--every`` CPU seconds, into ``--partial``
        next_dump = [args.every]
        sample = on_sample

        def on_sample(signum: int, frame: FrameType | None) -> None:  # noqa: F811 - the same, and the dump
            sample(signum, frame)
            if sum(counts.values()) >= next_dump[0]:
                next_dump[0] += args.every
                Path(args.partial).write_text(write_table(" (so far)"))

    signal.signal(signal.SIGPROF, on_sample)
    signal.setitimer(signal.ITIMER_PROF, args.interval / 1000, args.interval / 1000)
    try:
        rc = samplehd_main(["generate", *gen_args])
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0, 0)
    print(write_table(""), end="")
    return int(rc or 0)


if __name__ == "__main__":
    sys.exit(main())
