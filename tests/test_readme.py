"""The README says what the code does: every dotted ``mjcable.…`` name in it (and in the package's docstrings)
resolves by attribute access, and its table of default settings is the catalogue's."""

import ast
import dataclasses
import re
from pathlib import Path

import pytest

import mjcable
from mjcable import catalog

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")
SOURCES = sorted((ROOT / "mjcable").rglob("*.py"))
DOTTED = re.compile(r"(?<![\w/.-])mjcable(?:\.[A-Za-z_]\w*)+")
DEFAULTS_HEADING = "### Default settings"


def test_readme_names_some_dotted_names():
    assert len(set(DOTTED.findall(README))) >= 10


def _docstring_names() -> list:
    return sorted({name for path in SOURCES for name in DOTTED.findall(path.read_text(encoding="utf-8"))})


def _name_param(name: str):
    """A dotted name as a test parameter; names under ``mjcable.envs`` need dm_control (marker ``envs``)."""
    return pytest.param(name, marks=pytest.mark.envs) if name.startswith("mjcable.envs") else name


@pytest.mark.parametrize("name", [_name_param(n) for n in sorted(set(DOTTED.findall(README))) + _docstring_names()])
def test_every_dotted_name_in_the_readme_and_docstrings_resolves_by_attribute_access(name):
    obj = mjcable
    for part in name.split(".")[1:]:
        assert hasattr(obj, part), f"{name}: {obj!r} has no attribute {part!r}"
        obj = getattr(obj, part)


def _defaults_table() -> dict:
    """{model: {setting: value}} from the README's defaults table (`` `name=value` `` cells)."""
    start = README.index(DEFAULTS_HEADING)
    rows = {}
    for line in README[start:].splitlines()[1:]:
        if line.startswith("#"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not cells[0].startswith("`"):
            continue
        model = cells[0].strip("`")
        pairs = re.findall(r"`(\w+)=([^`]*)`", cells[-1])
        rows[model] = {k: ast.literal_eval(v) for k, v in pairs}
    return rows


def test_readme_defaults_table_is_the_catalogues():
    table = _defaults_table()
    assert set(table) == set(catalog.names()) | set(catalog.unavailable())  # composite is in it on MuJoCo 4 too
    for model, written in ((m, w) for m, w in table.items() if m in catalog.names()):
        defaults = dataclasses.asdict(catalog.make_settings(model))
        assert written == defaults, f"README defaults of {model!r} differ from the code's {defaults}"


BLOCKS = re.findall(r"```python\n(.*?)```", README, re.S)


def _needs(block: str) -> set:
    """The markers of what a README block needs: ``envs`` (dm_control: the environments, the Jaco world),
    ``composite`` (the cable plugin)."""
    needs = set()
    if re.search(r"\benvs\b|\bjaco\b", block):
        needs.add("envs")
    if '"composite"' in block:
        needs.add("composite")
    return needs


@pytest.mark.parametrize("index", [pytest.param(i, marks=[getattr(pytest.mark, m) for m in sorted(_needs(b))])
                                   for i, b in enumerate(BLOCKS)])
def test_readme_python_examples_run(index, tmp_path, monkeypatch):
    """Each ``python`` block of the README runs as written (in a scratch folder), after the ones before it that need
    no more than it does (a block without dm_control runs without the blocks that need it)."""
    monkeypatch.chdir(tmp_path)
    namespace = {}
    needs = _needs(BLOCKS[index])
    for block in [b for b in BLOCKS[:index] if _needs(b) <= needs] + [BLOCKS[index]]:
        exec(compile(block, "README.md", "exec"), namespace)  # noqa: S102 - the README's own examples
