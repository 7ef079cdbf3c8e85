"""One process at a time per dataset: an advisory ``flock`` on the dataset folder itself.

The folder's own descriptor is locked, not a lock file inside it, so taking the lock (or being refused
it) changes no byte of the dataset and leaves nothing behind; the kernel releases it when the process
ends, however it ends (exit, exception, ``kill -9``). Commands that change a dataset (generate, its
``--resume``, rerender) take it exclusively for their whole run; commands that only read it to write
something elsewhere (export) take it shared, so several exports can run together but none while the
dataset is being changed.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from samplehd.errors import DatasetError

__all__ = ["dataset_lock", "lock_holder"]

_PROC_LOCKS = Path("/proc/locks")


@contextmanager
def dataset_lock(root: str | Path, shared: bool = False) -> Iterator[None]:
    """Hold a lock on the dataset folder ``root`` for the ``with`` block.

    Args:
        root: an existing folder.
        shared: a read lock (others may read; nobody may write) instead of an exclusive one.

    Raises:
        DatasetError: another process holds a conflicting lock (one line naming its pid), or the
            folder cannot be opened.
    """
    root = Path(root)
    try:
        fd = os.open(root, os.O_RDONLY | os.O_DIRECTORY)
    except OSError as exc:
        raise DatasetError(f"{root}: cannot open the folder to lock it ({exc.strerror})") from None
    try:
        try:
            fcntl.flock(fd, (fcntl.LOCK_SH if shared else fcntl.LOCK_EX) | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = lock_holder(fd)
            who = f"process {pid}" if pid else "another process"
            raise DatasetError(f"{root}: in use by {who} (another samplehd command is writing or reading it); "
                               f"wait until it ends, or stop it and run this command again") from None
        yield
    finally:
        os.close(fd)


def lock_holder(fd: int) -> int | None:
    """The pid of a process holding a ``flock`` on the file open as ``fd`` (Linux ``/proc/locks``;
    None where it cannot be told)."""
    st = os.fstat(fd)
    try:
        lines = _PROC_LOCKS.read_text().splitlines()
    except OSError:
        return None
    for line in lines:
        fields = line.split()
        if "->" in fields or len(fields) < 6 or fields[1] != "FLOCK":
            continue
        try:
            major, minor, inode = fields[5].split(":")
            if (int(inode), int(major, 16), int(minor, 16)) == (st.st_ino, os.major(st.st_dev), os.minor(st.st_dev)):
                return int(fields[4])
        except ValueError:
            continue
    return None
