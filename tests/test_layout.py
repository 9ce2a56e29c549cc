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
README = ROOT.parent / "docs" / "architecture.md"  # the layout and the architecture


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
    assert "jaco.planners.compose" in GRAPH["jaco.planners.classic"]  # from .compose import
    assert "jaco.maps" in GRAPH["jaco.research.record_map"]  # from .. import maps
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
        with pytest.warns(DeprecationWarning, match=rf"^jaco\.{old} is deprecated; use jaco\.{re.escape(new)}$"):
            assert getattr(jaco, old) is importlib.import_module(f"jaco.{new}"), old


def test_the_moved_names_warn_every_time_and_are_not_listed():
    with pytest.warns(DeprecationWarning) as caught:
        assert jaco.pheromone is importlib.import_module("jaco.engine.pheromone")
        assert jaco.pheromone is importlib.import_module("jaco.engine.pheromone")
    assert [str(w.message) for w in caught] == ["jaco.pheromone is deprecated; use jaco.engine.pheromone"] * 2
    with pytest.warns(DeprecationWarning, match=r"^jaco\.variants is deprecated; use jaco\.planners\.registry$"):
        assert jaco.variants is not None
    with pytest.warns(DeprecationWarning, match=r"^jaco\.sweeps is deprecated; use jaco\.research\.sweeps$"):
        assert jaco.sweeps is not None
    assert not set(jaco._MOVED) & (set(jaco.__all__) | set(dir(jaco)))
    assert {"engine", "planners", "research", "solve"} <= set(dir(jaco))


_OLD_PATH = re.compile(r"\bjaco\.(?:" + "|".join(sorted(jaco._MOVED, key=len, reverse=True) + ["bitexact"]) + r")\b")


def _sources():
    top = ROOT.parent
    for folder in ("jaco", "tests", "experiments"):
        for path in sorted((top / folder).rglob("*.py")):
            if path != Path(__file__).resolve():
                yield path.relative_to(top).as_posix(), path.read_text(encoding="utf-8")
    for path in sorted((top / "notebooks").glob("*.ipynb")):
        yield path.relative_to(top).as_posix(), path.read_text(encoding="utf-8")


def test_nothing_uses_the_moved_names():
    """No code reaches a module by its old path (``jaco.sweeps``, ``from jaco import records``,
    ``import jaco.pheromone``), and no string, comment or notebook cites one."""
    moved = set(jaco._MOVED) | {"bitexact"}
    for name, text in _sources():
        if name.endswith(".py"):
            for node in ast.walk(ast.parse(text)):
                if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "jaco":
                    assert node.attr not in moved, f"{name}:{node.lineno}: jaco.{node.attr}"
                elif isinstance(node, ast.ImportFrom) and node.module == "jaco" and not node.level:
                    assert not moved & {a.name for a in node.names}, f"{name}:{node.lineno}"
                elif isinstance(node, ast.Import):
                    for alias in node.names:
                        parts = alias.name.split(".")
                        assert parts[0] != "jaco" or len(parts) == 1 or parts[1] not in moved, f"{name}:{node.lineno}"
        found = [m.group() for m in _OLD_PATH.finditer(text)]
        assert not found, f"{name} cites old module paths: {found}"


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
