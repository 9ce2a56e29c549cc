"""The package's layout: no import cycles, the layers the README's architecture names, and a tree
that matches the README's layout section.

The imports are read from the source with ``ast``, at module level and inside functions alike,
because an import inside a function is still a dependency, only a later one.
"""

import ast
import importlib
import re
from pathlib import Path

import pytest

import jaco

# The checkout's source tree, not the installed copy: CI installs jaco into site-packages, where
# neither the README nor (for a wheel) the same file list is found.
ROOT = Path(__file__).resolve().parents[1] / "jaco"
README = ROOT.parent / "README.md"


def _module_name(path: Path) -> str:
    parts = ("jaco",) + path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


FILES = {_module_name(p): p for p in sorted(ROOT.rglob("*.py"))}
MODULES = set(FILES)


def _is_package(module: str) -> bool:
    return FILES[module].name == "__init__.py"


def _imports(module: str) -> set[str]:
    """The jaco modules ``module`` imports: ``import a.b``, ``from a import b`` (``a.b`` when that
    is a module, else ``a``), relative imports resolved, plus every package a target lies in
    that ``module`` does not (importing ``jaco.maps.ros`` runs ``jaco/maps/__init__.py`` first)."""
    tree = ast.parse(FILES[module].read_text(encoding="utf-8"))
    package = module if _is_package(module) else module.rpartition(".")[0]
    targets = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                base = ".".join(base + ([node.module] if node.module else []))
            else:
                base = node.module
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                targets.add(sub if sub in MODULES else base)
    out = set()
    for target in targets:
        if target not in MODULES:
            continue
        out.add(target)
        parts = target.split(".")
        for i in range(1, len(parts)):
            parent = ".".join(parts[:i])
            if not (module == parent or module.startswith(parent + ".")):
                out.add(parent)
    out.discard(module)
    return out


GRAPH = {m: _imports(m) for m in MODULES}


def _cycles(graph) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each as a cycle."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
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
    return out


def _path(graph, a, b, allowed):
    """A shortest import chain a -> ... -> b inside ``allowed`` (to print a cycle)."""
    prev, frontier = {a: None}, [a]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & allowed):
                if w not in prev:
                    prev[w] = v
                    nxt.append(w)
        frontier = nxt
    chain, v = [], b
    while v is not None:
        chain.append(v)
        v = prev.get(v)
    return chain[::-1]


def test_the_graph_sees_imports_inside_functions_and_relative_ones():
    assert "jaco.research.record_format" in GRAPH["jaco.engine.result"]  # inside Result.save
    assert "jaco.engine.variant" in GRAPH["jaco.planners.classic"]  # from ..engine.variant import
    assert "jaco.maps" in GRAPH["jaco.research.record_format"]  # from .. import maps
    assert "jaco.engine" in GRAPH["jaco.apf"]  # the package runs before its module


def test_no_import_cycles():
    cycles = _cycles(GRAPH)
    shown = []
    for component in cycles:
        members = set(component)
        a = component[0]
        back = next(b for b in component if a in GRAPH[b])
        shown.append(" -> ".join(_path(GRAPH, a, back, members) + [a]))
    assert not cycles, "import cycles:\n" + "\n".join(shown)


def _reach(module: str) -> set[str]:
    seen, todo = set(), [module]
    while todo:
        for w in GRAPH[todo.pop()]:
            if w not in seen:
                seen.add(w)
                todo.append(w)
    return seen


def _under(modules, *packages) -> set[str]:
    return {m for m in modules if any(m == p or m.startswith(p + ".") for p in packages)}


ENGINE = _under(MODULES, "jaco.engine")
PLANNERS = _under(MODULES, "jaco.planners") - {"jaco.planners.registry"}


@pytest.mark.parametrize("module", sorted(ENGINE))
def test_the_engine_never_imports_what_is_built_on_it(module):
    """Planners, the registry, the front door, waypoints and research sit above the engine. The
    one exception is ``Result.save``/``save_path``, which delegate to the record writer; the
    writer reads a result by its attributes and never imports the run back."""
    above = _under(
        MODULES, "jaco.planners", "jaco.research", "jaco.api", "jaco.waypoints", "jaco.cli", "jaco.apf", "jaco.plot"
    )
    allowed = {"jaco.research", "jaco.research.record_format"} if module == "jaco.engine.result" else set()
    assert GRAPH[module] & above <= allowed


def test_the_record_writer_never_imports_the_run_back():
    reached = _reach("jaco.research.record_format")
    assert not reached & {"jaco.engine.run", "jaco.engine.result", "jaco.api", "jaco.research.records"}


@pytest.mark.parametrize("module", sorted(PLANNERS))
def test_planners_never_import_the_registry_or_anything_above(module):
    above = _under(MODULES, "jaco.research", "jaco.api", "jaco.waypoints", "jaco.cli", "jaco.apf")
    assert not GRAPH[module] & (above | {"jaco.planners.registry", "jaco.engine.run", "jaco.engine.result"})


def test_waypoints_sit_above_the_single_run():
    assert "jaco.waypoints" not in _reach("jaco.engine.run")
    assert "jaco.engine.run" in GRAPH["jaco.waypoints"]
    assert {"jaco.waypoints", "jaco.planners.registry", "jaco.engine.run"} <= GRAPH["jaco.api"]


def test_the_public_names_and_the_moved_modules_resolve():
    for name in jaco.__all__:
        assert getattr(jaco, name) is not None, name
    for old, new in jaco._MOVED.items():
        assert getattr(jaco, old) is importlib.import_module(f"jaco.{new}"), old


def _readme_section(title: str) -> str:
    text = README.read_text(encoding="utf-8")
    start = text.index(f"## {title}")
    end = text.find("\n## ", start + 1)
    return text[start : end if end >= 0 else None]


def _readme_tree() -> set[str]:
    """The ``.py`` paths of the tree drawn in the README's layout section (a fenced block, two
    spaces of indent per level)."""
    block = _readme_section("Layout").split("```")[1]
    dirs, paths = [], set()
    for line in block.strip("\n").splitlines():
        depth = (len(line) - len(line.lstrip(" "))) // 2
        entry = line.split()[0]
        del dirs[depth:]
        if entry.endswith("/"):
            dirs.append(entry)
        elif entry.endswith(".py"):
            paths.add("".join(dirs) + entry)
    return paths


def test_the_tree_matches_the_readme():
    """Every module is in the README's layout tree, every module there exists, and every path the
    architecture section names exists."""
    drawn = _readme_tree()
    actual = {p.relative_to(ROOT.parent).as_posix() for p in FILES.values()}
    assert actual - drawn == set(), "modules missing from the README's layout section"
    assert drawn - actual == set(), "the README's layout section names modules that do not exist"
    for path in re.findall(r"`(jaco/[\w/]+(?:\.py|/))`", _readme_section("Architecture")):
        assert (ROOT.parent / path).exists(), path
