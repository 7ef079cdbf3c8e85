"""The one rule for where a command may write, checked before it writes anything.

An output path is refused when

- it names the same file or folder as one of the command's inputs, or as another of its outputs;
- it is, or lies inside, a dataset folder (a samplehd dataset, or an export of one) — unless the
  command exists to update that very dataset (``generate --resume``, ``rerender``);
- one of its names, or the whole path, is longer than the file system allows.

Paths read *from* a dataset's files (``info.json``'s episode ``file``) are checked by
:func:`inside_dataset`: they must stay inside the dataset folder.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path

from samplehd.dataset.layout import EPISODE_DIR, INFO_FILE
from samplehd.errors import ConfigError, DatasetError
from samplehd.fileio import resolve_path

__all__ = ["check_outputs", "dataset_root_of", "inside_dataset"]

# A dataset folder holds one of these (file, folder) pairs: a samplehd dataset, a SAMPLE-HD export, a
# LeRobot export. Both are asked for: an info.json alone is too common a name to mark a dataset.
_DATASET_MARKERS = ((INFO_FILE, EPISODE_DIR), (INFO_FILE, "sequences"), (f"meta/{INFO_FILE}", "data"))


def dataset_root_of(path: Path) -> Path | None:
    """The nearest folder that is ``path`` or holds it and is a dataset folder, or None (``path`` resolved)."""
    path = path.resolve()
    for folder in (path, *path.parents):
        if any((folder / file).is_file() and (folder / sub).is_dir() for file, sub in _DATASET_MARKERS):
            return folder
    return None


def check_outputs(outputs: Mapping[str, Path | None], inputs: Mapping[str, Path | None] | None = None,
                  in_place: Path | None = None) -> None:
    """Refuse outputs that would overwrite an input, another output or a dataset (see the module).

    Args:
        outputs: option name (``--out``) -> path the command will write (None: not given).
        inputs: option name -> a file or folder the command reads (None: not given).
        in_place: the dataset folder the command updates, the only dataset it may write into.

    Raises:
        ConfigError: one line naming the option, the path and what is valid.
    """
    seen: dict[Path, str] = {}
    read = {flag: resolve_path(p, ConfigError, _label(flag, p)) for flag, p in (inputs or {}).items() if p is not None}
    for flag, path in outputs.items():
        if path is not None:
            _check_length(flag, path)
            resolve_path(path, ConfigError, _label(flag, path))
    own = resolve_path(in_place, ConfigError) if in_place is not None else None
    for flag, path in outputs.items():
        if path is None:
            continue
        target = path.resolve()
        if target in seen:
            raise ConfigError(f"{flag} {path}: {seen[target]} names the same file; give each output its own path")
        seen[target] = flag
        for in_flag, source in read.items():
            if target == source:
                raise ConfigError(f"{flag} {path}: is the command's input ({in_flag}); writing it would destroy "
                                  f"the input; choose another path")
        root = dataset_root_of(target)
        if root is not None and root != own:
            what = "is the dataset" if root == target else "lies inside the dataset"
            raise ConfigError(f"{flag} {path}: {what} {root} (only the commands that update a dataset write there); "
                              f"choose a path outside it")


def inside_dataset(root: Path, relative: object, where: str) -> Path:
    """``root / relative`` for a path read from one of the dataset's own files, refused unless it is a
    relative path that stays inside ``root``.

    Args:
        root: the dataset folder.
        relative: the value read (should be a relative path string such as ``episodes/s000000_00.h5``).
        where: the file and field it was read from, for the message.

    Raises:
        DatasetError: not a string, absolute, or leading outside the dataset.
    """
    if not isinstance(relative, str) or not relative:
        raise DatasetError(f"{where}: {relative!r} is not a file name; expected a path inside the dataset folder")
    candidate = Path(relative)
    resolved_root = resolve_path(root)
    if candidate.is_absolute() or ".." in candidate.parts or \
            resolved_root not in resolve_path(resolved_root / candidate, label=f"{where}: {relative!r}").parents:
        raise DatasetError(f"{where}: {relative!r} leads outside the dataset folder {root}; a dataset's files "
                           f"must lie inside it (a damaged or hostile info.json?)")
    return root / candidate


def _label(flag: str, path: Path) -> str:
    """How a message names an option's path: ``--out PATH`` (a flag that already holds it stays as it is)."""
    return flag if str(path) in flag else f"{flag} {path}"


def _check_length(flag: str, path: Path) -> None:
    """Each name within the file system's NAME_MAX, the whole path within PATH_MAX."""
    # Only the parents are asked about: a name over the limit makes the file system refuse the question.
    existing = next((p for p in path.absolute().parents if _is_dir(p)), Path("/"))
    name_max, path_max = _limit(existing, "PC_NAME_MAX", 255), _limit(existing, "PC_PATH_MAX", 4096)
    for name in _names(path):
        size = len(os.fsencode(name))
        if size > name_max:
            raise ConfigError(f"{flag} {str(path)[:80]}…: the name {name[:40]}… is {size} bytes; the file system "
                              f"allows at most {name_max}; choose a shorter name")
    size = len(os.fsencode(str(path.absolute())))
    if size >= path_max:
        raise ConfigError(f"{flag} {str(path)[:80]}…: the path is {size} bytes; the file system allows fewer than "
                          f"{path_max}; choose a shorter path")


def _is_dir(path: Path) -> bool:
    try:
        return path.is_dir()
    except OSError:  # a name too long for the file system
        return False


def _names(path: Path) -> Iterable[str]:
    return (part for part in path.parts if part not in ("/", "", ".", ".."))


def _limit(folder: Path, name: str, default: int) -> int:
    try:
        return int(os.pathconf(folder, name))
    except (OSError, ValueError):
        return default
