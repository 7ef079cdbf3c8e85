"""Publish an output directory atomically: build it under a temporary sibling name, rename at the end."""

from __future__ import annotations

import glob
import os
import shutil
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

from samplehd.dataset.container import write_error
from samplehd.dataset.lock import dataset_lock
from samplehd.dataset.reader import DatasetReader
from samplehd.errors import DatasetError

__all__ = ["export_source", "remove_stale_staging", "staged_directory"]


@contextmanager
def staged_directory(out: Path, source: Path | None = None) -> Iterator[Path]:
    """Yield a fresh temporary directory beside `out`; on success it replaces `out` (which must be absent
    or empty), on any error it is removed and `out` is left untouched. The staging folders of earlier
    runs that were killed (their process is gone) are removed first.

    Args:
        out: the folder to publish.
        source: the dataset being exported, held with a shared lock (see
            :func:`~samplehd.dataset.lock.dataset_lock`) until `out` is published.

    Raises:
        DatasetError: writing failed (disk full, permissions), with one line naming `out`; or
            `source` is being changed by another process.
    """

    with ExitStack() as held:
        if source is not None:
            held.enter_context(dataset_lock(source, shared=True))
        yield held.enter_context(_staged(out))


def remove_stale_staging(out: Path) -> None:
    """Remove ``.OUT.tmp-PID`` folders beside `out` whose process no longer runs (a killed export)."""
    prefix = f".{out.name}.tmp-"
    for p in out.parent.glob(f"{glob.escape(prefix)}*") if out.parent.is_dir() else ():
        pid = p.name[len(prefix):]
        if p.is_dir() and pid.isdigit() and not _running(int(pid)):
            shutil.rmtree(p, ignore_errors=True)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@contextmanager
def _staged(out: Path) -> Iterator[Path]:
    remove_stale_staging(out)
    tmp = out.with_name(f".{out.name}.tmp-{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        tmp.mkdir(parents=True)
        yield tmp
        if out.exists():
            out.rmdir()
        out.parent.mkdir(parents=True, exist_ok=True)
        os.replace(tmp, out)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise write_error(out, exc) from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def export_source(root: str | Path, out: str | Path) -> tuple[DatasetReader, Path]:
    """Open a finished dataset to export and check the export target is new or empty.

    Raises:
        DatasetError: generation has not finished, an episode file is missing or damaged, or `out`
            is a file, holds files or lies inside the dataset (one line).
    """

    reader = DatasetReader(root)
    if not reader.complete:
        raise DatasetError(f"{root}: generation has not finished; finish it first "
                           "(generate into it again with `resume`)")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise DatasetError(f"out={out}: is a file; choose a new folder", field="out")
    if out.resolve() == reader.root.resolve() or reader.root.resolve() in out.resolve().parents:
        raise DatasetError(f"out={out}: lies inside the dataset {root}; choose a folder outside it", field="out")
    if out.exists() and any(out.iterdir()):
        raise DatasetError(f"out={out}: exists and is not empty; choose a new folder", field="out")
    reader.check_intact()
    return reader, out
