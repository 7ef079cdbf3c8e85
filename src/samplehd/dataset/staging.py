"""Publish an output directory atomically: build it under a temporary sibling name, rename at the end."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from samplehd.dataset.container import write_error
from samplehd.dataset.reader import DatasetReader
from samplehd.errors import DatasetError

__all__ = ["export_source", "staged_directory"]


@contextmanager
def staged_directory(out: Path) -> Iterator[Path]:
    """Yield a fresh temporary directory beside `out`; on success it replaces `out` (which must be absent
    or empty), on any error it is removed and `out` is left untouched.

    Raises:
        DatasetError: writing failed (disk full, permissions), with one line naming `out`.
    """

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
        raise DatasetError(f"{root}: generation has not finished; run samplehd generate --resume first")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise DatasetError(f"--out {out}: is a file; choose a new folder")
    if out.resolve() == reader.root.resolve() or reader.root.resolve() in out.resolve().parents:
        raise DatasetError(f"--out {out}: lies inside the dataset {root}; choose a folder outside it")
    if out.exists() and any(out.iterdir()):
        raise DatasetError(f"--out {out}: exists and is not empty; choose a new folder")
    reader.check_intact()
    return reader, out
