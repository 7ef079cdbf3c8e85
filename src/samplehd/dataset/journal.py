"""``journal.jsonl``: an append-only record of finished path work units, for resume.

One JSON object per line, written by the coordinating process only (workers return results to it):
``{"scene_index", "slot", "status": "ok" | "rejected", ...}``. A process killed while appending can
leave a torn last line; readers ignore lines that do not parse, and :func:`repair_journal` cuts the
file back to its last complete line before a resumed run appends to it.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, TypedDict

from samplehd.dataset.container import write_error
from samplehd.dataset.layout import JOURNAL_FILE, RESUME_HINT

__all__ = ["JournalRecord", "append_journal", "read_journal", "repair_journal"]


class JournalRecord(TypedDict, total=False):
    """One line of the journal: a path work unit's outcome (:class:`samplehd.dataset.work.EpisodeResult`,
    whose attributes say what each key means; a key is left out where it does not apply)."""

    scene_index: int
    slot: int
    status: str
    seconds: float
    cpu_seconds: float
    reason: str
    message: str
    attempts: int
    num_frames: int
    size: int
    sha256: str
    path_seconds: float
    render_seconds: float
    path_cpu_seconds: float
    render_cpu_seconds: float
    write_cpu_seconds: float
    success: bool
    disturbance: str
    outcome: str


def read_journal(root: Path) -> list[JournalRecord]:
    """Every complete record of ``root/journal.jsonl`` (none if the file is absent)."""
    path = Path(root) / JOURNAL_FILE
    if not path.exists():
        return []
    out = []
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            if not line.endswith("\n"):
                break  # torn by a kill
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(rec, dict):
                out.append(rec)
    return out


def repair_journal(root: Path) -> None:
    """Cut a torn last line off the journal."""
    path = Path(root) / JOURNAL_FILE
    if not path.exists():
        return
    data = path.read_bytes()
    end = data.rfind(b"\n") + 1
    if end != len(data):
        with open(path, "rb+") as f:
            f.truncate(end)


def append_journal(root: Path, records: Iterable[Mapping[str, Any]]) -> None:
    """Append records (one line each) and flush them to disk.

    Raises:
        DatasetError: the journal cannot be written (disk full, permissions), one line.
    """
    text = "".join(json.dumps(dict(r), sort_keys=True) + "\n" for r in records)
    if not text:
        return
    path = Path(root) / JOURNAL_FILE
    try:
        with open(path, "a", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
    except OSError as exc:
        raise write_error(path, exc, RESUME_HINT) from None
