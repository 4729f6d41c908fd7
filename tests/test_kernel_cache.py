"""The numba cache of the kernel files is stamped with ALL kernel files (mjcable.solvers._kernel_cache), so that a
driver importing its callees from a sibling file never loads stale machine code. Fast: nothing is compiled."""
import inspect
import os
import shutil

import pytest
from numba.core.caching import CacheImpl

from mjcable import spline
from mjcable.solvers import _kernel_cache, constraint_kernels, direct_kernels, host_kernels, kernels, query_kernels

pytestmark = pytest.mark.skipif(not _kernel_cache.CACHE, reason="kernel caching disabled (numba internals missing)")


def _ours():
    return [c for c in CacheImpl._locator_classes if c.__module__ == _kernel_cache.__name__]


def _first_locator(func):
    """The locator numba picks for ``func`` (its own loop in CacheImpl.__init__)."""
    py_file = inspect.getfile(func)
    for cls in CacheImpl._locator_classes:
        loc = cls.from_function(func, py_file)
        if loc is not None:
            return loc
    return None


def test_locators_registered_first_and_used_by_kernel_dispatchers():
    ours = _ours()
    assert len(ours) == 3 and CacheImpl._locator_classes[:3] == ours
    for dispatcher in (kernels.run_steps, kernels.substep, host_kernels.host_after, constraint_kernels.curvature_sweep,
                       direct_kernels.direct_solve, query_kernels.proxy_poses):
        assert type(_first_locator(dispatcher.py_func)) in ours
        assert type(dispatcher._cache._impl.locator) in ours  # the dispatcher's own cache
        # numba's per-function file name and disambiguator (first line number) are kept
        assert dispatcher._cache._impl.locator.get_disambiguator() == str(dispatcher.py_func.__code__.co_firstlineno)


def test_other_files_keep_numba_locators():
    njitted = [v for v in vars(spline).values() if hasattr(v, "py_func")]
    assert njitted
    assert type(_first_locator(njitted[0].py_func)) not in _ours()
    for cls in _ours():
        assert cls.from_function(njitted[0].py_func, inspect.getfile(njitted[0].py_func)) is None


def test_kernel_files_cover_the_split():
    names = {os.path.basename(f) for f in _kernel_cache.kernel_files()}
    assert {"kernels.py", "constraint_kernels.py", "direct_kernels.py", "kernels_layout.py", "host_kernels.py", "monitor_kernels.py",
            "query_kernels.py"} <= names


def test_stamp_changes_when_another_kernel_file_changes(tmp_path):
    """A temporary copy of the kernel files: touching a callee file (new content and mtime) changes the stamp of
    the driver file's functions. numba >= 0.61 hashes a file's content (keyed by mtime and size), older numba
    stamps (mtime, size): a change of both counts under either."""
    for f in _kernel_cache.kernel_files():
        shutil.copy2(f, tmp_path / os.path.basename(f))
    (tmp_path / "unrelated.py").write_text("X = 1\n")
    cls = next(c for c in _ours() if c.__name__ == "KernelCacheLocator")
    driver = cls(kernels.run_steps.py_func, str(tmp_path / "kernels.py"))
    stamp0 = driver.get_source_stamp()
    assert driver.get_source_stamp() == stamp0  # deterministic

    (tmp_path / "unrelated.py").write_text("X = 2\n")  # not a kernel file: no effect
    assert driver.get_source_stamp() == stamp0

    callee = tmp_path / "constraint_kernels.py"
    st = os.stat(callee)
    callee.write_text(callee.read_text() + "\n# changed\n")
    os.utime(callee, ns=(st.st_atime_ns, st.st_mtime_ns + 10**10))
    stamp1 = driver.get_source_stamp()
    assert stamp1 != stamp0

    # every kernel file's functions see the same combined stamp
    other = cls(direct_kernels.direct_solve.py_func, str(tmp_path / "direct_kernels.py"))
    assert other.get_source_stamp() == stamp1
