"""The solver state's layout (issue 18): named fields, no hand-kept index tables, and kernels that take a handful of
parameters (the state itself where they need many of its arrays)."""

import ast
import importlib
import inspect
import pkgutil
import re

import pytest

import mjcable
from mjcable.solvers import kernels_layout

MAX_KERNEL_PARAMETERS = 12
#: the index-table constants the named fields replaced (columns of fric, shapes, impulse, parameters, capacities,
#: host columns, link columns)
OLD_INDEX_NAMES = re.compile(r"^(FR_\w+|SH_\w+|IM_\w+|PS_\w+|N_FR|N_SH|FP\w*|IP\w*|LIM\w*|CAPI\w*|HC\w*|LK\w*)$")


def _modules(package):
    for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
        if info.name.endswith("__main__"):  # runs the command line
            continue
        try:
            yield importlib.import_module(info.name)
        except ImportError:  # optional extras (rendering, environments) that this machine lacks
            continue


def _kernels():
    """Every numba dispatcher defined in an mjcable module: (qualified name, dispatcher)."""
    seen = {}
    for module in _modules(mjcable):
        for name, obj in vars(module).items():
            if hasattr(obj, "py_func") and obj.py_func.__module__ == module.__name__:
                seen[f"{module.__name__}.{name}"] = obj
    return seen


def test_the_walk_finds_the_kernels():
    names = _kernels()
    for expected in ("mjcable.solvers.kernels.run_steps", "mjcable.solvers.contact_kernels.contact_sweep",
                     "mjcable.solvers.query_kernels.query_obstacles", "mjcable.solvers.host_kernels.host_after"):
        assert expected in names


def test_no_compiled_function_takes_more_than_12_parameters():
    too_many = {name: len(inspect.signature(k.py_func).parameters) for name, k in _kernels().items()
                if len(inspect.signature(k.py_func).parameters) > MAX_KERNEL_PARAMETERS}
    assert not too_many, f"pass the state (or a small tuple) instead: {too_many}"


def _module_constants(path):
    """Names bound at a module's top level (assignments, tuple assignments)."""
    tree = ast.parse(path.read_text())
    names = set()
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(
            node, (ast.AnnAssign, ast.AugAssign)) else []
        for target in targets:
            for t in ast.walk(target):
                if isinstance(t, ast.Name):
                    names.add(t.id)
    return names


@pytest.mark.parametrize("path", sorted((p for p in __import__("pathlib").Path(mjcable.solvers.__file__).parent.glob(
    "*.py")), key=str), ids=lambda p: p.name)
def test_no_solver_module_defines_an_index_table(path):
    old = sorted(n for n in _module_constants(path) if OLD_INDEX_NAMES.match(n))
    assert not old, f"{path.name} defines column indices {old}: use named fields of the state (kernels_layout.FIELDS)"


def test_every_field_is_set_once_by_a_setter_of_at_most_12_parameters():
    names = [n for _, names in kernels_layout._PARTS for n in names]
    assert sorted(names) == sorted(n for n, _, _ in kernels_layout.FIELDS)
    for setter, part in kernels_layout._PARTS:
        assert len(inspect.signature(setter.py_func).parameters) == len(part) + 1 <= MAX_KERNEL_PARAMETERS
