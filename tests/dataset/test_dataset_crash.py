"""Crash safety for real: SIGKILL a generating process, resume, compare with an uninterrupted run;
disk-full and Ray runs in real subprocesses / a real local Ray instance."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest
from dataset_helpers import fingerprint, micro_config, micro_config_file

from samplehd.dataset.journal import read_journal
from samplehd.dataset.validate import validate_dataset

CLI = [sys.executable, "-m", "samplehd"]


def _wait_for(pred, timeout: float) -> bool:  # noqa: ANN001
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if pred():
            return True
        time.sleep(0.05)
    return False


def test_kill9_mid_run_then_resume_gives_the_uninterrupted_dataset(micro_dataset: Path, tmp_path: Path) -> None:
    from samplehd.dataset.generate import generate_dataset

    out = tmp_path / "ds"
    cmd = [*CLI, "generate", "--preset", "tiny", "--config", str(micro_config_file(tmp_path)), "--out", str(out),
           "--workers", "2", "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        # Kill once the first path unit is recorded: scenes done, other units in flight in the workers.
        started = _wait_for(lambda: (out / "journal.jsonl").exists() and (out / "journal.jsonl").stat().st_size > 0,
                            timeout=240)
        assert started, proc.stderr.read().decode() if proc.poll() is not None else "no progress in 240 s"
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert json.loads((out / "info.json").read_text())["status"] == "in_progress"
    assert validate_dataset(out)[0]  # unfinished: reported, not crashed
    generate_dataset(out, micro_config(), resume=True)
    assert validate_dataset(out)[0] == []
    assert fingerprint(out) == fingerprint(micro_dataset)
    keys = Counter((r["scene_index"], r["slot"]) for r in read_journal(out))
    assert max(keys.values()) == 1  # nothing done twice
    assert not [p for p in (out / "episodes").iterdir() if p.name.startswith(".")]


@pytest.mark.slow  # about 25 s: a generate in a subprocess
def test_sigterm_mid_run_stops_cleanly_without_leaked_semaphores(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    cmd = [*CLI, "generate", "--preset", "tiny", "--config", str(micro_config_file(tmp_path)), "--out", str(out),
           "--workers", "2", "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        # Once the first scene is written, the worker pool (and its queues' semaphores) is running.
        started = _wait_for(lambda: (out / "scenes").is_dir() and any((out / "scenes").iterdir()), timeout=240)
        assert started, proc.stderr.read().decode() if proc.poll() is not None else "no progress in 240 s"
        proc.send_signal(signal.SIGTERM)  # to the coordinating process only, as `kill PID` does
        _, err = proc.communicate(timeout=120)  # to EOF: the resource tracker's warnings included
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    text = err.decode()
    assert "leaked semaphore" not in text and "Traceback" not in text, text
    assert proc.returncode == 130 and text.strip().endswith("samplehd generate: interrupted"), text
    assert json.loads((out / "info.json").read_text())["status"] == "in_progress"


def _small_filesystem(tmp_path: Path, kib: int) -> tuple[Path, list[str]]:
    """A directory on a tiny tmpfs (when we may mount) or a `ulimit -f` prefix for the command."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={kib}k", "tmpfs", str(mnt)], capture_output=True)
        if r.returncode == 0:
            return mnt, []
    # No mount: a file-size limit makes writes fail with EFBIG (SIGXFSZ ignored so the write errors).
    return mnt, ["bash", "-c", f"trap '' XFSZ; ulimit -f {kib}; exec \"$0\" \"$@\""]


def _run_on_small_disk(tmp_path: Path, kib: int, args: list[str]) -> subprocess.CompletedProcess:
    mnt, prefix = _small_filesystem(tmp_path, kib)
    try:
        return subprocess.run([*prefix, *[a.replace("{SMALL}", str(mnt)) for a in args]], capture_output=True,
                              text=True, timeout=300)
    finally:
        if not prefix:
            subprocess.run(["umount", str(mnt)], capture_output=True)


def test_disk_full_while_generating_is_one_clear_line(tmp_path: Path) -> None:
    r = _run_on_small_disk(tmp_path, 48, [*CLI, "generate", "--preset", "tiny", "--config",
                                          str(micro_config_file(tmp_path)), "--out", "{SMALL}/ds", "--quiet"])
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1 and "disk is full" in lines[0], r.stderr


def test_disk_full_while_writing_an_episode_is_one_clear_line(micro_dataset: Path, tmp_path: Path) -> None:
    code = ("import sys; from samplehd.cli import main; from samplehd.dataset.reader import DatasetReader\n"
            "from samplehd.dataset.container import write_episode; from samplehd.errors import DatasetError\n"
            f"ep = DatasetReader({str(micro_dataset)!r}).episode(0)\n"
            "try:\n    write_episode(__import__('pathlib').Path(sys.argv[1]) / 'e.h5', ep)\n"
            "except DatasetError as e:\n    print(e, file=sys.stderr); sys.exit(2)\n")
    r = _run_on_small_disk(tmp_path, 64, [sys.executable, "-c", code, "{SMALL}"])
    assert r.returncode == 2 and "disk is full" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_ray_backend_gives_the_same_dataset(micro_dataset: Path, tmp_path: Path) -> None:
    ray = pytest.importorskip("ray")
    from samplehd.dataset.generate import generate_dataset
    from samplehd.workers import Backend

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        generate_dataset(tmp_path / "ds", micro_config(), Backend("ray", 2))
    finally:
        ray.shutdown()
    assert fingerprint(tmp_path / "ds") == fingerprint(micro_dataset)
