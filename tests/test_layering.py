"""planners/ and kinematics/ are pure; they and app/ are layered.

- Importing planners or kinematics pulls in no viser, app or plotting; the app's session
  (the controller and its parts) pulls in no viser either.
- Imports point down only: no cycle between modules and none between subpackages
  (docs/architecture.md). Imports inside functions count (they run too); imports under
  ``if TYPE_CHECKING:`` do not (they never run).
- Each folder is a room one can hold in one's head: at most about a dozen modules.
- Privacy is marked on modules, not on names: no module uses another module's private
  (``_x``) name, and a private module (``_x.py``) is imported only from its own folder.

The structural checks are parametrized by package: planners, kinematics and app.
"""

from __future__ import annotations

import ast
import textwrap
from pathlib import Path

import pytest

from tests.conftest import ROOT, run_code

PURE = ["planners", "kinematics"]
"""Packages that import no viser, no app and no plotting."""
PACKAGES = [*PURE, "app"]
MAX_MODULES = 12
"""Modules (``__init__.py`` not counted) a folder may hold."""


@pytest.mark.parametrize("package", PURE)
def test_pure_packages_do_not_import_viser(package):
    code = (
        f"import sys, {package}\n"
        "bad = [m for m in ('viser', 'app', 'matplotlib', 'playwright') if m in sys.modules]\n"
        "print(','.join(bad))\n"
    )
    out = run_code(code).strip()
    assert out == "", f"{package} imported {out}"


def test_the_apps_session_does_not_import_viser():
    # A worker process needs the controller's parts only (app/__init__ imports lazily).
    code = (
        "import sys, app.session.controller, app.session.lanes, app.session.pool\n"
        "bad = [m for m in ('viser', 'app.ui', 'app.media', 'playwright')"
        " if m in sys.modules]\n"
        "print(','.join(bad))\n"
    )
    out = run_code(code).strip()
    assert out == "", f"app.session imported {out}"


# --------------------------------------------------------------------------- the graph


def modules_of(package: str, root: Path = ROOT) -> dict[str, Path]:
    """Return every module of ``package`` (a folder under ``root``) by dotted name."""
    out = {}
    for path in sorted((root / package).rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _runtime_nodes(node: ast.AST):
    """Yield every node below ``node`` except the bodies of ``if TYPE_CHECKING:``."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.If) and _is_type_checking(child.test):
            for other in child.orelse:
                yield other
                yield from _runtime_nodes(other)
            continue
        yield child
        yield from _runtime_nodes(child)


def _resolve(name: str, here: str, is_package: bool, level: int) -> str:
    if not level:
        return name
    base = here.split(".") if is_package else here.split(".")[:-1]
    base = base[: len(base) - level + 1]
    return ".".join([*base, name] if name else base)


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Return the modules of ``modules`` that module ``name`` imports when it runs.

    ``from a import b`` names module ``a.b`` when there is one, else ``a``; ``import
    a.b.c`` names ``a.b.c``; ``importlib.import_module("a.b")`` with a literal names
    ``a.b``. Imports in functions count; those under ``if TYPE_CHECKING:`` do not.
    """
    tree = ast.parse(path.read_text(), str(path))
    is_package = path.name == "__init__.py"
    found = set()
    for node in _runtime_nodes(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            source = _resolve(node.module or "", name, is_package, node.level)
            targets = [
                f"{source}.{a.name}" if f"{source}.{a.name}" in modules else source
                for a in node.names
            ]
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, (ast.Attribute, ast.Name))
            and getattr(node.func, "attr", getattr(node.func, "id", ""))
            in ("import_module", "__import__")
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            targets = [node.args[0].value]
        found.update(_module_of(t, modules) for t in targets)
    return found - {"", name}


def _module_of(dotted: str, modules: dict[str, Path]) -> str:
    """Return the longest prefix of ``dotted`` that is a module ("" if none is)."""
    while dotted and dotted not in modules:  # a name in a module: the module
        dotted = dotted.rpartition(".")[0]
    return dotted


def import_graph(package: str, root: Path = ROOT) -> dict[str, set[str]]:
    """Return, per module of ``package``, the modules of ``package`` it imports."""
    modules = modules_of(package, root)
    return {name: imports_of(name, path, modules) for name, path in modules.items()}


def room_of(module: str, package: str) -> str:
    """Return the subpackage ``module`` lives in; a module of the top folder is its own."""
    parts = module.split(".")
    if module == package or len(parts) == 2:  # the package itself, a top-level module
        return module
    return ".".join(parts[:2])


def room_graph(graph: dict[str, set[str]], package: str) -> dict[str, set[str]]:
    """Return the graph between subpackages (and top-level modules) of ``graph``."""
    rooms: dict[str, set[str]] = {}
    for module, targets in graph.items():
        here = room_of(module, package)
        rooms.setdefault(here, set())
        rooms[here] |= {room_of(t, package) for t in targets} - {here}
    return rooms


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Return the strongly connected components of ``graph`` with more than one node.

    >>> cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}})
    [['a', 'b', 'c']]
    >>> cycles({"a": {"b"}, "b": set()})
    []
    """
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out = []

    def visit(v: str) -> None:  # Tarjan; the graphs are a few dozen nodes deep at most
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def private_crossings(package: str, root: Path = ROOT) -> list[str]:
    """Return each use of a private name of one module of ``package`` in another one.

    ``from a import _x`` and ``a._x`` (``a`` an imported module of the package), where
    ``a`` is not the module itself; dunder names are not private.
    """
    modules = modules_of(package, root)
    out = []
    for name, path in modules.items():
        tree = ast.parse(path.read_text(), str(path))
        bound, imported = _names_imported(tree, name, path, modules)
        out += [
            f"{name}:{line} {source}.{n}"
            for source, n, line in imported
            if source in modules and source != name and _private(n)
        ]
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr):
                chain = []
                value: ast.expr = node.value
                while isinstance(value, ast.Attribute):
                    chain.append(value.attr)
                    value = value.value
                if isinstance(value, ast.Name):
                    target = ".".join([bound.get(value.id, value.id), *reversed(chain)])
                    if target in modules and target != name:
                        out.append(f"{name}:{node.lineno} {target}.{node.attr}")
    return sorted(out)


def _names_imported(
    tree: ast.Module, name: str, path: Path, modules: dict[str, Path]
) -> tuple[dict[str, str], list[tuple[str, str, int]]]:
    """Return the local names bound to modules, and every (module, name, line) imported."""
    bound: dict[str, str] = {}
    imported = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            source = _resolve(
                node.module or "", name, path.name == "__init__.py", node.level
            )
            for a in node.names:
                if f"{source}.{a.name}" in modules:
                    bound[a.asname or a.name] = f"{source}.{a.name}"
                else:
                    imported.append((source, a.name, node.lineno))
        elif isinstance(node, ast.Import):
            bound.update({a.asname: a.name for a in node.names if a.asname})
    return bound, imported


def private_module_strays(graph: dict[str, set[str]]) -> list[str]:
    """Return each import of a private module (``_x.py``) from outside its folder."""
    return [
        f"{module} -> {target}"
        for module, targets in sorted(graph.items())
        for target in sorted(targets)
        if _private(target.rpartition(".")[2])
        and not (module + ".").startswith(target.rpartition(".")[0] + ".")
    ]


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


# --------------------------------------------------------------------------- the checks


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycle_between_modules(package):
    assert cycles(import_graph(package)) == []


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycle_between_subpackages(package):
    assert cycles(room_graph(import_graph(package), package)) == []


@pytest.mark.parametrize("package", PACKAGES)
def test_every_folder_holds_about_a_dozen_modules_at_most(package):
    folders = {
        p.parent: sorted(
            q.name for q in p.parent.glob("*.py") if q.name != "__init__.py"
        )
        for p in (ROOT / package).rglob("__init__.py")
    }
    crowded = {
        str(f.relative_to(ROOT)): len(m)
        for f, m in folders.items()
        if len(m) > MAX_MODULES
    }
    assert crowded == {}


@pytest.mark.parametrize("package", PACKAGES)
def test_no_private_name_crosses_a_module_boundary(package):
    assert private_crossings(package) == []


@pytest.mark.parametrize("package", PACKAGES)
def test_a_private_module_is_imported_from_its_own_folder_only(package):
    assert private_module_strays(import_graph(package)) == []


def test_the_checks_can_fail(tmp_path):
    # A package whose modules import each other inside a function, a private name and a
    # private module from the next folder; a type-only import ties nothing.
    files = {
        "pkg/__init__.py": "",
        "pkg/a/__init__.py": "",
        "pkg/a/one.py": "from pkg.b.two import _helper\n",
        "pkg/b/__init__.py": "",
        "pkg/b/two.py": "def f():\n    from pkg.a import one\n\n\ndef _helper():\n    pass\n",
        "pkg/b/_three.py": (
            "from typing import TYPE_CHECKING\n"
            "if TYPE_CHECKING:\n    from pkg.a.one import x\n"
        ),
        "pkg/c.py": "import pkg.b._three\n",
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(textwrap.dedent(text))
    graph = import_graph("pkg", tmp_path)
    assert graph["pkg.b._three"] == set()
    assert cycles(graph) == [["pkg.a.one", "pkg.b.two"]]
    assert cycles(room_graph(graph, "pkg")) == [["pkg.a", "pkg.b"]]
    assert private_crossings("pkg", tmp_path) == ["pkg.a.one:1 pkg.b.two._helper"]
    assert private_module_strays(graph) == ["pkg.c -> pkg.b._three"]
