"""One numba cache freshness for all kernel files: a compiled kernel is stale when ANY kernel file changed.

Numba's on-disk cache (``cache=True``) keys a function's cache by its own source file: a driver in one file that
calls (or inlines, or reads a constant from) a function in another file would keep its stale machine code after
only the callee changed. This module registers a cache locator, at the front of numba's list, whose source stamp
combines numba's own per-file stamps of every ``mjcable/solvers/*kernels*.py`` (and of this module: it holds the
compile options), so that the kernel files may import from one another. Everything else stays numba's: the cache
directory (``__pycache__`` beside the file, ``NUMBA_CACHE_DIR`` or the user-wide one, in numba's order), the file
names and the per-function disambiguator. Functions in other files get numba's stock locators.

These are numba internals (``numba.core.caching``). Where they are missing, or where ``NUMBA_CACHE_LOCATOR_CLASSES``
replaces numba's locator list without naming ours, :data:`CACHE` is False and the kernel files compile in every
process (with a warning) rather than risk a stale cache. Every kernel file imports :data:`jit` and :data:`inline`
from here, before its first ``@njit``.
"""

from __future__ import annotations

import fnmatch
import glob
import os
import types
import warnings

import numba
from numba.extending import intrinsic

KERNEL_PATTERN = "*kernels*.py"
_HERE = os.path.dirname(os.path.realpath(__file__))
_THIS = os.path.realpath(__file__)


def kernel_files(directory: str = _HERE) -> list[str]:
    """The kernel files of ``directory`` (default: this package's), sorted: the files one stamp covers."""
    return sorted(glob.glob(os.path.join(directory, KERNEL_PATTERN)))


def is_kernel_file(py_file: str) -> bool:
    """Whether ``py_file`` is one of this package's kernel files."""
    path = os.path.realpath(py_file)
    return os.path.dirname(path) == _HERE and fnmatch.fnmatch(os.path.basename(path), KERNEL_PATTERN)


def _make_locators():
    """The locator classes, or a reason why not (numba internals missing)."""
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None)
    classes = getattr(impl, "_locator_classes", None)
    bases = [getattr(caching, n, None) for n in ("UserProvidedCacheLocator", "InTreeCacheLocator",
                                                 "UserWideCacheLocator")]
    if not isinstance(classes, list) or any(b is None for b in bases):
        return None, "numba.core.caching lacks CacheImpl._locator_classes or its source-file cache locators"
    if not all(callable(getattr(b, "get_source_stamp", None)) and hasattr(b, "from_function") for b in bases):
        return None, "numba's cache locators lack get_source_stamp/from_function"
    file_stamp = bases[1].get_source_stamp  # numba's own stamp of one file (reads self._py_file)

    class _AllKernelFilesMixin:
        """Source stamp: numba's stamps of every kernel file beside this function's file, and of _kernel_cache."""

        def get_source_stamp(self):
            files = kernel_files(os.path.dirname(os.path.realpath(self._py_file)))
            if _THIS not in files:
                files.append(_THIS)
            return tuple((os.path.basename(f), file_stamp(types.SimpleNamespace(_py_file=f))) for f in files)

        @classmethod
        def from_function(cls, py_func, py_file):
            if not is_kernel_file(py_file):
                return None  # not ours: numba's next locator
            return super().from_function(py_func, py_file)

    class KernelUserProvidedCacheLocator(_AllKernelFilesMixin, bases[0]):
        """numba's UserProvidedCacheLocator (``NUMBA_CACHE_DIR``) with the all-kernel-files stamp."""

    class KernelCacheLocator(_AllKernelFilesMixin, bases[1]):
        """numba's InTreeCacheLocator (``__pycache__``) with the all-kernel-files stamp."""

    class KernelUserWideCacheLocator(_AllKernelFilesMixin, bases[2]):
        """numba's UserWideCacheLocator (read-only install) with the all-kernel-files stamp."""

    return (KernelUserProvidedCacheLocator, KernelCacheLocator, KernelUserWideCacheLocator), None


def _register() -> bool:
    """Put the locators at the front of numba's list (once). False (with a warning) where that cannot work."""
    try:
        locators, why = _make_locators()
    except Exception as exc:  # an import or attribute error in numba's internals
        locators, why = None, f"{type(exc).__name__}: {exc}"
    override = getattr(numba.config, "CACHE_LOCATOR_CLASSES", "")
    if locators is not None and override and not any(c.__name__ in override for c in locators):
        why = "NUMBA_CACHE_LOCATOR_CLASSES replaces numba's locator list"
        locators = None
    if locators is None:
        warnings.warn(f"mjcable: numba kernel caching disabled ({why}); kernels compile in every process",
                      RuntimeWarning, stacklevel=3)
        return False
    from numba.core.caching import CacheImpl

    names = {c.__qualname__ for c in locators}
    CacheImpl._locator_classes[:] = [c for c in CacheImpl._locator_classes if c.__qualname__ not in names]
    CacheImpl._locator_classes[:0] = list(locators)
    return True


CACHE = _register()


@intrinsic
def variable(typingctx, value):
    """``value`` as a run-time variable of its type, not a compile-time constant. A compiled function called from
    another with a constant argument (``f(S, True)``, ``f(S, 0, 1)``) is typed, and compiled, once per constant
    (numba's ``Literal`` types): ``f(S, variable(True))`` compiles the one version every call site shares."""
    out = numba.types.unliteral(value)

    def codegen(context, builder, signature, args):
        return context.cast(builder, args[0], signature.args[0], signature.return_type)

    return out(value), codegen
jit = numba.njit(cache=CACHE, error_model="numpy")
inline = numba.njit(cache=CACHE, error_model="numpy", inline="always")
#: for the drivers Python calls with real work (whole steps, substeps, the self-contact search): they release the GIL
#: so that the copies of an :class:`mjcable.Batch` step at once on threads. The small per-step helpers keep it:
#: every release is a chance for another thread to take the GIL, and a handoff costs more than they run.
nogil = numba.njit(cache=CACHE, error_model="numpy", nogil=True)
