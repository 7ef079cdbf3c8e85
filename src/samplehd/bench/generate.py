"""Dataset generation end to end in CPU seconds per frame: ``samplehd generate`` as a whole process.

``samplehd bench generate`` runs ``samplehd generate --preset P --scenes N --render none --seed S
--workers W`` in fresh processes and takes each run's CPU time from the operating system's accounting
of the finished process tree (user + system of the command and its workers, ``wait4``), so the figure
does not move with what else runs on a shared machine the way wall time does. Each variant runs once
untimed first (numba's on-disk cache, the catalogue's files, the page cache), then the variants take
turns, one run each per round, so that a drift of the machine's speed falls on all of them alike.

A variant is this checkout with one config (``--configs FILE ... ``, ``preset`` for the preset as it
is) or another checkout (``--against DIR``: its ``src`` goes first on ``PYTHONPATH``; with
``--against-config FILE``). The report gives each variant's frames, CPU seconds and frames per
CPU-second (median, min–max over the rounds) and its ratio to the last variant (the ``--against``
checkout when given), taken round by round: median and min–max. Nothing here is asserted in tests.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from samplehd.errors import ConfigError, DatasetError

__all__ = ["Run", "Variant", "add_arguments", "measure", "report"]

# The package's source directory (samplehd/ lies in it): this checkout's, put first on PYTHONPATH.
_SRC = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Variant:
    """One thing to time.

    Attributes:
        name: label in the report.
        src: the source directory put first on ``PYTHONPATH`` (the one holding ``samplehd/``).
        config: a ``--config`` JSON file for ``samplehd generate`` (None: the preset as it is).
    """

    name: str
    src: Path
    config: Path | None = None


@dataclass(frozen=True)
class Run:
    """One finished ``samplehd generate`` process.

    Attributes:
        cpu_seconds: user + system CPU time of the process and its workers [s].
        wall_seconds: its wall time [s].
        frames: frames of the dataset it wrote.
        episodes: episodes of that dataset.
        returncode: the process's exit status.
    """

    cpu_seconds: float
    wall_seconds: float
    frames: int
    episodes: int
    returncode: int

    @property
    def frames_per_cpu_second(self) -> float:
        return self.frames / self.cpu_seconds if self.cpu_seconds > 0 else 0.0


@contextmanager
def _interrupts_held() -> Iterator[None]:
    """Within the block, Ctrl-C and SIGTERM wait; they are raised again, in the order they came, as the block
    ends. An interrupt that landed inside ``subprocess.Popen`` (after the fork, while it waits for the exec)
    would unwind before the caller holds the new process, which would then run on, orphaned. Off the main
    thread (where no handler can be set) the block runs unchanged."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    signums = (signal.SIGINT, signal.SIGTERM)
    previous = {s: signal.signal(s, lambda signum, _frame: caught.append(signum)) for s in signums}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        for s in dict.fromkeys(caught):
            signal.raise_signal(s)


def generate_once(variant: Variant, args: list[str], root: Path) -> Run:
    """Run ``samplehd generate ARGS --out DIR`` of ``variant`` in a fresh process under ``root``; the
    dataset is deleted after its counts are read."""
    out = Path(tempfile.mkdtemp(dir=root)) / "ds"
    cmd = [sys.executable, "-m", "samplehd", "generate", *args, "--quiet", "--out", str(out)]
    if variant.config is not None:
        cmd += ["--config", str(variant.config)]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(variant.src), os.environ.get("PYTHONPATH", "")]).rstrip(
        os.pathsep))
    t0 = time.perf_counter()
    proc: subprocess.Popen[bytes] | None = None
    try:
        with _interrupts_held():  # the child exists from its fork on: it must be known before an interrupt lands
            proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        assert proc.stderr is not None
        err = proc.stderr.read()
        _, status, usage = os.wait4(proc.pid, 0)
    except BaseException:  # interrupted (Ctrl-C, or SIGTERM as one): the run it timed stops with it
        if proc is not None:
            proc.terminate()
            proc.wait()
        shutil.rmtree(out.parent, ignore_errors=True)
        raise
    proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    frames = episodes = 0
    try:
        counts = json.loads((out / "info.json").read_text())["counts"]
        frames, episodes = int(counts["frames"]), int(counts["episodes"])
    except (OSError, ValueError, KeyError):
        pass
    finally:
        shutil.rmtree(out.parent, ignore_errors=True)
    if proc.returncode != 0 or not frames:
        last = err.decode(errors="replace").strip().splitlines()[-1:] or ["no output"]
        raise DatasetError(f"bench generate: {variant.name}: samplehd generate exited {proc.returncode} "
                           f"({frames} frames): {last[0]}")
    return Run(usage.ru_utime + usage.ru_stime, wall, frames, episodes, proc.returncode)


def measure(variants: list[Variant], args: list[str], repeats: int, warmup: int = 1,
            root: Path | None = None, log: bool = True) -> dict[str, list[Run]]:
    """``warmup`` untimed runs of every variant, then ``repeats`` rounds in which each runs once, in turn."""
    root = Path(tempfile.mkdtemp(prefix="bench_generate_", dir=root))
    runs: dict[str, list[Run]] = {v.name: [] for v in variants}
    try:
        for i in range(warmup + repeats):
            for v in variants:
                run = generate_once(v, args, root)
                if i >= warmup:
                    runs[v.name].append(run)
                if log:
                    print(f"  {'warm-up' if i < warmup else f'round {i - warmup + 1}'} {v.name}: {run.frames} frames, "
                          f"{run.cpu_seconds:.1f} CPU s, {run.wall_seconds:.1f} s wall, "
                          f"{run.frames_per_cpu_second:.0f} frames/CPU-s", flush=True)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    return runs


def _spread(values: list[float], fmt: str) -> str:
    return f"{format(statistics.median(values), fmt)} ({format(min(values), fmt)}–{format(max(values), fmt)})"


def table(runs: dict[str, list[Run]]) -> str:
    """A Markdown table of the runs; ratios against the last variant, round by round."""
    names = list(runs)
    ref = runs[names[-1]]
    lines = ["| variant | episodes | frames | CPU s | wall s | frames per CPU-s | ratio to "
             f"{names[-1]} |", "|---|---|---|---|---|---|---|"]
    for name in names:
        rs = runs[name]
        ratios = [r.frames_per_cpu_second / b.frames_per_cpu_second for r, b in zip(rs, ref, strict=True)]
        cpu, wall = [r.cpu_seconds for r in rs], [r.wall_seconds for r in rs]
        lines.append(f"| {name} | {rs[0].episodes:,} | {rs[0].frames:,} | {_spread(cpu, '.1f')} "
                     f"| {_spread(wall, '.1f')} "
                     f"| {_spread([r.frames_per_cpu_second for r in rs], '.0f')} | {_spread(ratios, '.3f')} |")
    return "\n".join(lines) + "\n"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """``samplehd bench generate``: frames per CPU-second of ``samplehd generate``, checkouts alternating."""
    parser.add_argument("--preset", default="sample-hd", help="preset of samplehd generate (default: sample-hd)")
    parser.add_argument("--scenes", type=int, default=30, help="scenes per run (default: 30)")
    parser.add_argument("--workers", type=int, default=2, help="workers per run (default: 2)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=3, help="timed rounds (default: 3)")
    parser.add_argument("--warmup", type=int, default=1, help="untimed rounds first (default: 1)")
    parser.add_argument("--configs", nargs="+", default=["preset"], metavar="FILE",
                        help="one variant of this checkout per --config FILE of samplehd generate; 'preset': none")
    parser.add_argument("--against", type=Path, metavar="DIR", help="another checkout to alternate with (its src/)")
    parser.add_argument("--against-config", type=Path, metavar="FILE", help="--config FILE for the --against checkout")


def variants_of(args: argparse.Namespace) -> list[Variant]:
    """The variants the arguments name, checked (one-line errors naming the flag and the value)."""
    for flag, v, lo, hi in (("--scenes", args.scenes, 1, 100_000), ("--workers", args.workers, 1, 256),
                            ("--repeats", args.repeats, 1, 100), ("--warmup", args.warmup, 0, 10)):
        if not lo <= v <= hi:
            raise ConfigError(f"{flag} {v}: must be an integer in {lo}..{hi}")
    out = []
    for c in args.configs:
        config = None if c == "preset" else Path(c)
        if config is not None and not config.is_file():
            raise ConfigError(f"--configs {c}: no such file (a JSON config of samplehd generate, or 'preset')")
        out.append(Variant("this checkout" + ("" if config is None else f", {config.name}"), _SRC, config))
    if args.against is not None:
        src = args.against / "src"
        if not (src / "samplehd" / "__init__.py").is_file():
            raise ConfigError(f"--against {args.against}: not a samplehd checkout (no src/samplehd/__init__.py)")
        if args.against_config is not None and not args.against_config.is_file():
            raise ConfigError(f"--against-config {args.against_config}: no such file")
        name = f"{args.against}" + ("" if args.against_config is None else f", {args.against_config.name}")
        out.append(Variant(name, src, args.against_config))
    elif args.against_config is not None:
        raise ConfigError(f"--against-config {args.against_config}: needs --against DIR")
    return out


def report(args: argparse.Namespace) -> int:
    """Time the variants in turn and print the table."""
    variants = variants_of(args)
    gen = ["--preset", args.preset, "--scenes", str(args.scenes), "--render", "none", "--seed", str(args.seed),
           "--workers", str(args.workers)]
    print(f"samplehd generate {' '.join(gen)}: {len(variants)} variant(s), {args.warmup} warm-up and "
          f"{args.repeats} timed round(s), load average {os.getloadavg()[0]:.1f}", flush=True)
    runs = measure(variants, gen, args.repeats, args.warmup)
    print(table(runs), end="")
    print(f"load average at the end {os.getloadavg()[0]:.1f}; CPU s: user + system of each process and its workers")
    return 0
