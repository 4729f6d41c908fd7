"""Atomic writes (mjcable.io): the destination holds its old content or the whole new one, whatever happens to the
writer, and no temporary file is left, not even by a writer killed with SIGKILL mid-write."""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from mjcable import io

IO_MODULE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "mjcable", "io.py")


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith(io.TEMP_PREFIX))


@pytest.fixture(params=["anonymous", "named"])
def kind(request, monkeypatch):
    """Both ways of making the temporary file: anonymous (O_TMPFILE, where Linux has it) and named (elsewhere)."""
    if request.param == "named":
        monkeypatch.delattr(os, "O_TMPFILE", raising=False)
    elif not hasattr(os, "O_TMPFILE"):
        pytest.skip("no O_TMPFILE on this platform")
    return request.param


def test_a_write_that_fails_leaves_the_old_file(tmp_path, kind):
    path = tmp_path / "a.txt"
    with io.atomic_write(path) as f:
        f.write("hello")
        assert not path.exists()  # nothing visible until complete
    assert path.read_text() == "hello"
    with pytest.raises(KeyError):
        with io.atomic_write(path) as f:
            f.write("half")
            f.flush()
            raise KeyError("interrupted")
    assert path.read_text() == "hello"
    with io.atomic_write(path) as f:  # over an existing file
        f.write("again")
    assert path.read_text() == "again"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_arrays_and_paths_for_other_writers(tmp_path, kind):
    x = np.arange(12.0).reshape(4, 3)
    with io.atomic_write(tmp_path / "x.npy", "wb") as f:
        np.save(f, x)
    np.testing.assert_array_equal(np.load(tmp_path / "x.npy"), x)
    # a path another process writes to in place (as ffmpeg does)
    with io.atomic_path(tmp_path / "copy.npy") as tmp:
        subprocess.run(["cp", str(tmp_path / "x.npy"), str(tmp)], check=True)
    np.testing.assert_array_equal(np.load(tmp_path / "copy.npy"), x)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["copy.npy", "x.npy"]
    if kind == "anonymous":  # a finished file gets a new file's permissions (mkstemp's are owner-only)
        umask = os.umask(0)
        os.umask(umask)
        assert (tmp_path / "x.npy").stat().st_mode & 0o777 == 0o666 & ~umask


def test_bad_destination_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        with io.atomic_write(tmp_path / "missing" / "a.txt"):
            pass
    with pytest.raises(ValueError, match="mode"):
        with io.atomic_write(tmp_path / "a.txt", "a"):
            pass


@pytest.mark.skipif(not hasattr(os, "O_TMPFILE"), reason="a named temporary file survives SIGKILL")
@pytest.mark.parametrize("text_mode", [True, False])
def test_a_writer_killed_mid_write_leaves_the_old_file_and_nothing_else(tmp_path, text_mode):
    path = tmp_path / "table.md"
    path.write_text("old")
    # mjcable/io.py alone (standard library only), so that the child starts fast
    code = textwrap.dedent(f"""
        import importlib.util, os, signal
        spec = importlib.util.spec_from_file_location("atomic_io", {IO_MODULE!r})
        io = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(io)
        if {text_mode}:
            with io.atomic_write({str(path)!r}) as f:
                f.write("half of the new" * 1000)
                f.flush()
                os.kill(os.getpid(), signal.SIGKILL)
        else:
            with io.atomic_path({str(path)!r}) as tmp:
                with open(tmp, "wb") as f:
                    f.write(b"half of the new" * 1000)
                os.kill(os.getpid(), signal.SIGKILL)
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert proc.returncode == -9, proc.stderr.decode()
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.md"]
