"""ruff is clean over the repository, the import-linter contracts in pyproject.toml are kept, and mypy passes
on the model packages (core, km, painting: the ``[tool.mypy]`` section of pyproject.toml)."""

from __future__ import annotations

import ast
import functools
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def _tool(name: str) -> str:
    path = BIN / name
    if path.exists():
        return str(path)
    found = shutil.which(name)
    if found is None:
        pytest.fail(f"{name} is not installed (it is in the 'test' extra)")
    return found


def test_ruff_clean() -> None:
    proc = subprocess.run([_tool("ruff"), "check", "--no-cache", "."], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_import_contracts_kept() -> None:
    proc = subprocess.run([_tool("lint-imports"), "--no-cache"], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]


def test_mypy_passes_on_the_model_packages() -> None:
    # mypy's own incremental cache, the one `mypy` run by hand in the checkout keeps (.mypy_cache, which
    # mypy keeps out of git with a .gitignore of its own): unchanged modules are not checked again (a
    # change rechecks the module and those that depend on it; a new mypy or configuration, everything)
    proc = subprocess.run([_tool("mypy"), "--cache-dir", str(ROOT / ".mypy_cache")], cwd=ROOT, capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stdout[-5000:] + proc.stderr[-2000:]
    assert "Success" in proc.stdout


# ---------------------------------------------------------------------------------------------- shape
#: The product's packages (tests/ and scripts/ are not held to the rules below).
PRODUCT = ("core", "km", "shade", "painting", "project", "render", "capture", "catalogue", "app", "bench", "resources")


@functools.cache
def _product_trees() -> tuple[tuple[str, tuple[ast.AST, ...]], ...]:
    """Each product module's path and every node of its tree (``ast.walk``'s order), parsed and walked once
    for the module's tests (which only read them)."""
    out = []
    for package in PRODUCT:
        for path in sorted((ROOT / package).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            out.append((path.relative_to(ROOT).as_posix(), tuple(ast.walk(tree))))
    return tuple(out)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _type_checking_nodes(nodes: tuple[ast.AST, ...]) -> set[int]:
    """The ids of every node inside an ``if TYPE_CHECKING:`` block (declarations, not definitions)."""
    out: set[int] = set()
    for node in nodes:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.body:
                out.update(id(n) for n in ast.walk(child))
    return out


def _defined_names(nodes: tuple[ast.AST, ...], declared: set[int]) -> set[str]:
    """Every name a module defines: functions, classes, assigned names and attributes, arguments, imports,
    ``__slots__`` entries and ``setattr``'s names (a bare annotation declares, it does not define).

    ``nodes``: the module's nodes; ``declared``: those in ``if TYPE_CHECKING:`` blocks
    (:func:`_type_checking_nodes`).
    """
    skip = set(declared)
    for node in nodes:
        if isinstance(node, ast.AnnAssign) and node.value is None:
            skip.update(id(n) for n in ast.walk(node.target))
    names: set[str] = set()
    for node in nodes:
        if id(node) in skip:
            continue
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Attribute, ast.Name)) and isinstance(node.ctx, ast.Store):
            names.add(node.attr if isinstance(node, ast.Attribute) else node.id)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
        elif isinstance(node, ast.alias):
            names.add(node.asname or node.name.split(".")[0])
        elif isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__slots__"
                                                  for t in node.targets):
            names.update(c.value for c in ast.walk(node.value) if isinstance(c, ast.Constant))
        elif (isinstance(node, ast.Call) and ast.unparse(node.func).endswith("setattr") and len(node.args) > 1
              and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str)):
            names.add(node.args[1].value)
    return names


#: Private members reached through another object than ``self``/``cls`` that stay allowed, (file,
#: expression) each. Only a class's own internals, reached from its own module; and two of the standard
#: library's names, which have no public spelling.
PRIVATE_ACCESS_ALLOWED = {
    # WavelengthGrid.from_wavelengths makes a grid without __init__ and fills it with the class's own _init
    ("km/spectra.py", "obj._init"),
    # WavelengthGrid.__eq__ compares the other grid's own fields
    ("km/spectra.py", "other._hash"),
    ("km/spectra.py", "other._wl"),
    # the Atlas dataclass's cache file, recorded by its own module's bake (the bake made or loaded it)
    ("painting/atlas.py", "cached._cache_path"),
    ("painting/atlas.py", "atlas._cache_path"),
    # KioskConfig.load (a classmethod) reads the fields the class's instances persist
    ("app/kiosk/config.py", "cfg._persisted"),
    # the standard library: os._exit is os's documented way to end a process at once (the fuzzer's
    # forked writers die mid-save on purpose)
    ("bench/fuzz.py", "os._exit"),
    # the standard library: argparse has no public way to take option values that start with a minus
    # sign ("--light -12,5,1"); tests/app/commands/test_render_cli.py holds it to that
    ("app/commands/render.py", "p._negative_number_matcher"),
}


def test_no_module_uses_another_modules_private_members() -> None:
    """No module reaches another's private members: ``obj._name`` (obj not ``self``/``cls``) outside the
    allow-list, ``self._name`` where the module does not define ``_name`` (a mixin calling its host's
    internals), or ``from module import _name``."""
    found = []
    for rel, nodes in _product_trees():
        declared = _type_checking_nodes(nodes)
        defined = _defined_names(nodes, declared)
        for node in nodes:
            if id(node) in declared:
                continue
            if isinstance(node, ast.Attribute) and _private(node.attr):
                owner = node.value
                if isinstance(owner, ast.Name) and owner.id in ("self", "cls"):
                    if node.attr not in defined:
                        found.append(f"{rel}:{node.lineno}: {ast.unparse(node)} ({node.attr} is not this module's)")
                elif (rel, ast.unparse(node)) not in PRIVATE_ACCESS_ALLOWED:
                    found.append(f"{rel}:{node.lineno}: {ast.unparse(node)}")
            elif isinstance(node, ast.ImportFrom):
                found += [f"{rel}:{node.lineno}: from {'.' * node.level}{node.module or ''} import {a.name}"
                          for a in node.names if _private(a.name)]
    assert not found, "private members of another module (give the owner a public method):\n" + "\n".join(found)


def test_the_app_never_reaches_through_the_view_into_its_renderer() -> None:
    """``app`` asks the view (:class:`render.view.ViewRenderer`) for what it needs: never ``….r.…``."""
    found = [f"{rel}:{node.lineno}: {ast.unparse(node)}" for rel, nodes in _product_trees() if rel.startswith("app/")
             for node in nodes if isinstance(node, ast.Attribute) and node.attr == "r"]
    assert not found, "the view's own renderer reached from the app:\n" + "\n".join(found)


#: The most lines of code (from the first statement after the docstring to the function's last line) a product
#: function may run to without saying why in its docstring.
LONG_FUNCTION_LINES = 80


def _code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """The function's lines of code, its docstring left out (a long explanation is no long function)."""
    body = node.body
    has_doc = isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
        and isinstance(body[0].value.value, str)
    first = body[1] if has_doc and len(body) > 1 else body[0]
    return (node.end_lineno or first.lineno) - first.lineno + 1


def test_long_product_functions_say_why() -> None:
    """A product function of more than :data:`LONG_FUNCTION_LINES` lines of code is split by concern, or its
    docstring has a paragraph starting "Long:" that says why it reads better whole (a compiled kernel, one
    GL draw's objects released in one place…)."""
    found = []
    for rel, nodes in _product_trees():
        for node in nodes:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = _code_lines(node)
                if lines > LONG_FUNCTION_LINES and "Long:" not in (ast.get_docstring(node) or ""):
                    found.append(f"{rel}:{node.lineno}: {node.name} ({lines} lines of code)")
    assert not found, (f"functions over {LONG_FUNCTION_LINES} lines of code without a 'Long:' reason in their "
                       "docstring:\n" + "\n".join(sorted(found)))
