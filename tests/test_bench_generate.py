"""``samplehd bench generate``: it runs ``samplehd generate`` in fresh processes and prints frames per
CPU-second with ratios taken round by round. (The figures themselves are never asserted.)"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from samplehd.bench.generate import Run, table
from samplehd.cli import main


def test_table_gives_medians_ranges_and_ratios_round_by_round() -> None:
    runs = {"new": [Run(10.0, 20.0, 1000, 4, 0), Run(12.5, 25.0, 1000, 4, 0), Run(8.0, 16.0, 1000, 4, 0)],
            "old": [Run(10.0, 20.0, 900, 4, 0), Run(10.0, 20.0, 900, 4, 0), Run(10.0, 20.0, 900, 4, 0)]}
    text = table(runs)
    # frames per CPU-second 100 / 80 / 125 against 90 each round: ratios 1.111 / 0.889 / 1.389
    assert "| new | 4 | 1,000 | 10.0 (8.0–12.5) | 20.0 (16.0–25.0) | 100 (80–125) | 1.111 (0.889–1.389) |" in text
    assert "| old | 4 | 900 | 10.0 (10.0–10.0) | 20.0 (20.0–20.0) | 90 (90–90) | 1.000 (1.000–1.000) |" in text


@pytest.mark.slow
def test_bench_generate_runs_and_prints_its_figures(tmp_path: Path, capsys) -> None:
    config = tmp_path / "one.json"
    config.write_text('{"instructions": {"per_scene": 1}}')
    assert main(["bench", "generate", "--preset", "tiny", "--scenes", "1", "--workers", "1", "--repeats", "1",
                 "--warmup", "0", "--configs", str(config)]) == 0
    out = capsys.readouterr().out
    row = re.search(r"\| this checkout, one.json \| 1 \| ([\d,]+) \| [\d.]+ \([\d.]+–[\d.]+\) .* \| 1.000 ", out)
    assert row is not None, out
    assert int(row.group(1).replace(",", "")) > 0


def _children(pid: int) -> list[int]:
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(c) for c in path.read_text().split()] if path.exists() else []


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="reads child processes from Linux's /proc")
def test_a_terminated_bench_stops_the_generate_it_was_timing(tmp_path: Path) -> None:
    import os
    import signal
    import subprocess
    import sys
    import time

    timed: list[int] = []
    bench = subprocess.Popen([sys.executable, "-m", "samplehd", "bench", "generate", "--preset", "tiny", "--scenes",
                              "50", "--workers", "1", "--repeats", "1", "--warmup", "0"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)
    try:
        deadline = time.monotonic() + 120
        while not (timed := _children(bench.pid)) and time.monotonic() < deadline and bench.poll() is None:
            time.sleep(0.1)
        assert timed, "the bench never started its generate"
        bench.send_signal(signal.SIGTERM)
        bench.wait(timeout=60)
        deadline = time.monotonic() + 30
        alive = timed
        while alive and time.monotonic() < deadline:
            alive = [p for p in timed if Path(f"/proc/{p}").exists()
                     and Path(f"/proc/{p}/stat").read_text().split()[2] != "Z"]
            time.sleep(0.1)
        assert not alive, f"generate {alive} outlived its bench"
    finally:
        if bench.poll() is None:
            bench.kill()
        for p in timed:  # none is left running, whatever the outcome
            try:
                os.kill(p, signal.SIGKILL)
            except ProcessLookupError:
                pass


def test_an_interrupt_inside_the_spawn_still_stops_the_generate(tmp_path: Path, monkeypatch) -> None:
    """SIGTERM that lands while ``subprocess.Popen`` has forked but not yet returned (the window the test
    above hits now and then on a loaded machine) still stops the run: it waits for the spawn to finish."""
    import os
    import signal
    import subprocess

    from samplehd.bench import generate as bench_generate
    from samplehd.commands._options import sigterm_as_interrupt

    spawned: list[subprocess.Popen[bytes]] = []
    popen = subprocess.Popen

    def popen_then_sigterm(*args, **kwargs):  # the real spawn; the signal lands before the caller holds it
        proc = popen(*args, **kwargs)
        spawned.append(proc)
        os.kill(os.getpid(), signal.SIGTERM)
        return proc

    monkeypatch.setattr(bench_generate.subprocess, "Popen", popen_then_sigterm)
    variant = bench_generate.Variant("this checkout", bench_generate._SRC, None)
    try:
        with sigterm_as_interrupt(), pytest.raises(KeyboardInterrupt):
            bench_generate.generate_once(variant, ["--preset", "tiny", "--scenes", "50", "--workers", "1"], tmp_path)
        assert len(spawned) == 1
        assert spawned[0].poll() is not None, "the generate outlived the interrupted bench"
        assert list(tmp_path.iterdir()) == []  # its dataset folder went with it
    finally:
        for proc in spawned:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
