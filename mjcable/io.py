"""Atomic file writing: a reader never sees a half-written file.

Everything goes to a temporary file in the destination folder (same file system), which replaces the destination
with ``os.replace`` only once it is complete; on any error the temporary file is removed and the destination is left
as it was.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterator, Union

__all__ = ["atomic_path", "atomic_write", "TEMP_PREFIX"]

TEMP_PREFIX = ".mjcable-tmp-"  # temporary files start with this (hidden; tests look for leftovers)
_FILE_MODE = 0o644  # mkstemp creates 0600 files; finished files get the usual permissions

PathLike = Union[str, os.PathLike]


@contextlib.contextmanager
def atomic_path(path: PathLike) -> Iterator[Path]:
    """A temporary path next to ``path`` that replaces ``path`` when the block exits without error.

    The temporary name keeps ``path``'s suffix, so tools that infer a format from it (ffmpeg) still work. The
    destination folder must exist.

    Args:
      path: the destination file.

    Yields:
      The temporary path to write to (the file exists, empty).

    Example::

        with atomic_path("out.mp4") as tmp:
            mediapy.write_video(tmp, frames, fps=30)
    """
    dest = Path(path)
    folder = dest.parent
    if not folder.is_dir():
        raise ValueError(f"path {str(path)!r} is in a folder that does not exist ({str(folder)!r}); create it first")
    fd, tmp = tempfile.mkstemp(prefix=TEMP_PREFIX, suffix=dest.suffix, dir=folder)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.chmod(tmp_path, _FILE_MODE)
        os.replace(tmp_path, dest)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()


@contextlib.contextmanager
def atomic_write(path: PathLike, mode: str = "w", **open_kwargs):
    """Open a temporary file next to ``path`` that replaces ``path`` when the block exits without error.

    Args:
      path: the destination file.
      mode: ``"w"`` (text, UTF-8 unless ``encoding`` is given) or ``"wb"``.
      **open_kwargs: passed to ``open`` (``encoding``, ``newline``).

    Example::

        with atomic_write("models/hang_springs.xml") as f:
            f.write(xml)
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    if mode == "w":
        open_kwargs.setdefault("encoding", "utf-8")
    with atomic_path(path) as tmp:
        with open(tmp, mode, **open_kwargs) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
