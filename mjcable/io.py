"""Atomic file writing: a reader never sees a half-written file, and a killed writer leaves nothing behind.

Every output of mjcable (plots, tables, arrays, videos, exported models) goes through :func:`atomic_path` or
:func:`atomic_write`: the content is written to a temporary file in the destination folder (same file system) and
takes the destination's name only once it is complete and synced, so the destination holds either its old content
or the whole new one. Where Linux allows it (``O_TMPFILE``: ext4, xfs, btrfs, tmpfs), the temporary file has no name
until then (writers that need a path get ``/proc/<pid>/fd/<fd>``), so a process killed at any moment, even by
SIGKILL, leaves no temporary file. Elsewhere it is a hidden file (:data:`TEMP_PREFIX`) in the destination folder,
renamed over the destination with ``os.replace`` and removed on any error or interrupt; only a SIGKILL leaves it.
An anonymous file replacing an existing destination is linked under a hidden name for the instant of the rename.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import tempfile
from pathlib import Path
from typing import Iterator, Tuple, Union

__all__ = ["atomic_path", "atomic_write", "TEMP_PREFIX"]

TEMP_PREFIX = ".mjcable-tmp-"  # named temporary files start with this (hidden; tests look for leftovers)
_FILE_MODE = 0o644  # mkstemp creates 0600 files; finished files get the usual permissions
_NEW_FILE_MODE = 0o666  # an anonymous file's mode before the umask, as open() gives a new file

PathLike = Union[str, os.PathLike]


@contextlib.contextmanager
def atomic_path(path: PathLike) -> Iterator[Path]:
    """A temporary path in ``path``'s folder whose content replaces ``path`` when the block exits without error.

    The path may have no suffix (an anonymous file's ``/proc/<pid>/fd/<fd>``, which other processes such as ffmpeg
    can open too): tell the writer the format (``savefig(tmp, format="png")``, ffmpeg's ``-f mp4``). The writer
    must write the file in place (open it, truncate, write), not rename another file onto it.

    Args:
      path: the destination file; its folder must exist.

    Yields:
      The temporary path to write to (the file exists, empty).

    Raises:
      ValueError: ``path``'s folder does not exist.

    Example::

        with atomic_path("out.mp4") as tmp:
            mediapy.write_video(tmp, frames, fps=30, ffmpeg_args=["-f", "mp4"])
    """
    dest = Path(path)
    if not dest.parent.is_dir():
        raise ValueError(f"path {str(path)!r} is in a folder that does not exist ({str(dest.parent)!r}); "
                         "create it first")
    fd, tmp, anonymous = _open_temp(dest)
    try:
        yield Path(tmp)
        os.fsync(fd)  # the content is on disk before any name points at it
        if anonymous:
            _link(tmp, dest)
        else:
            os.chmod(tmp, _FILE_MODE)
            os.replace(tmp, dest)
    finally:
        os.close(fd)
        if not anonymous:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)


@contextlib.contextmanager
def atomic_write(path: PathLike, mode: str = "w", **open_kwargs):
    """Open a temporary file whose content replaces ``path`` when the block exits without error
    (:func:`atomic_path`).

    Args:
      path: the destination file; its folder must exist.
      mode: ``"w"`` (text, UTF-8 unless ``encoding`` is given) or ``"wb"``.
      **open_kwargs: passed to ``open`` (``encoding``, ``newline``).

    Example::

        with atomic_write("models/hang_springs.xml") as f:
            f.write(xml)
        with atomic_write("out/positions.npy", "wb") as f:
            np.save(f, x)
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    if mode == "w":
        open_kwargs.setdefault("encoding", "utf-8")
    with atomic_path(path) as tmp:
        with open(tmp, mode, **open_kwargs) as f:
            yield f


def _open_temp(dest: Path) -> Tuple[int, str, bool]:
    """``(fd, path, anonymous)``: an anonymous file (``O_TMPFILE``) in ``dest``'s folder where the kernel, the
    file system and ``/proc`` allow, else a named temporary file there."""
    flag = getattr(os, "O_TMPFILE", None)
    fds = f"/proc/{os.getpid()}/fd"
    if flag is not None and os.path.isdir(fds):
        try:
            fd = os.open(dest.parent, flag | os.O_RDWR, _NEW_FILE_MODE)
        except OSError:  # no anonymous files here (file system, kernel): a named one below
            pass
        else:
            return fd, f"{fds}/{fd}", True
    fd, tmp = tempfile.mkstemp(prefix=TEMP_PREFIX, suffix=dest.suffix, dir=dest.parent)
    return fd, tmp, False


def _link(fd_path: str, dest: Path) -> None:
    """Give the anonymous file at ``fd_path`` the name ``dest``: linked directly where ``dest`` does not exist,
    else linked under a hidden name that then replaces ``dest``."""
    folder = os.open(dest.parent, os.O_RDONLY | os.O_DIRECTORY)
    try:
        # linkat(AT_SYMLINK_FOLLOW) on /proc/<pid>/fd/<fd> (os.link uses linkat only when given a dir fd)
        try:
            os.link(fd_path, dest.name, dst_dir_fd=folder, follow_symlinks=True)
            return
        except FileExistsError:
            pass
        name = f"{TEMP_PREFIX}{secrets.token_hex(8)}{dest.suffix}"
        os.link(fd_path, name, dst_dir_fd=folder, follow_symlinks=True)
        try:
            os.replace(name, dest.name, src_dir_fd=folder, dst_dir_fd=folder)
        except BaseException:
            os.unlink(name, dir_fd=folder)
            raise
    finally:
        os.close(folder)
