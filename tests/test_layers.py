"""The package's layers (docs/DEVELOPING.md): one dependency direction, no import circle.

cli -> experiments -> runtimes -> robot -> team / navigation / measure / policies -> maps ->
the plumbing at the top (errors, params, topics, paths, plain, files). `ros/` (the rospy
adapters) sits beside `cli/`; nothing imports either of them. Imports inside functions count.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "tpuaf_ros" / "src" / "tpuaf"

# Rank of each sub-package (higher may import lower or equal, never higher). Top-level modules
# are rank 0.
RANKS = {
    "maps": 1,
    "team": 2, "navigation": 2, "measure": 2, "policies": 2,
    "robot": 3,
    "runtimes": 4,
    "experiments": 5,
    "cli": 6, "ros": 6,
}
ONLY_FROM_ITSELF = ("cli", "ros")  # no other layer imports these


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imports_of(path: Path) -> set[str]:
    """Every tpuaf module `path` imports (absolute or relative, at any depth of the code)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    me = module_name(path).split(".")
    package = me if path.name == "__init__.py" else me[:-1]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] == "tpuaf")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            if module.split(".")[0] != "tpuaf":
                continue
            found.add(module)
            for alias in node.names:  # `from tpuaf.team import bus` imports tpuaf.team.bus
                candidate = f"{module}.{alias.name}"
                if (PACKAGE.parent / Path(*candidate.split("."))).with_suffix(".py").is_file() \
                        or (PACKAGE.parent / Path(*candidate.split(".")) / "__init__.py").is_file():
                    found.add(candidate)
    return found


def graph(package: Path = PACKAGE) -> dict[str, set[str]]:
    modules = {module_name(p): p for p in sorted(package.rglob("*.py"))}
    return {name: {m for m in imports_of(path) if m in modules and m != name}
            for name, path in modules.items()}


def layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 2 or (len(parts) == 2 and parts[1] in RANKS) else ""


def violations(deps: dict[str, set[str]]) -> list[str]:
    found = []
    for module, imported in deps.items():
        mine = layer(module)
        for other in imported:
            theirs = layer(other)
            if theirs in ONLY_FROM_ITSELF and theirs != mine:
                found.append(f"{module} imports {other}: nothing outside {theirs}/ may")
            elif RANKS.get(theirs, 0) > RANKS.get(mine, 0):
                found.append(f"{module} ({mine or 'top'}) imports {other} ({theirs}), a higher "
                             f"layer")
    return sorted(found)


def cycles(deps: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), i.e. import circles.
    A package importing its own sub-modules from __init__ is not a circle unless they import
    it back."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(deps.get(v, ())):
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
                found.append(sorted(component))

    for v in sorted(deps):
        if v not in index:
            visit(v)
    return found


def without_parent_packages(deps: dict[str, set[str]]) -> dict[str, set[str]]:
    """`import tpuaf.a.b` also runs tpuaf/__init__ and tpuaf/a/__init__; those edges from a
    module to its own parent packages are not design dependencies."""
    return {m: {d for d in ds if not m.startswith(d + ".")} for m, ds in deps.items()}


def test_every_import_goes_down_the_layers():
    assert violations(graph()) == []


def test_no_import_circle():
    assert cycles(without_parent_packages(graph())) == []


def test_every_sub_package_has_a_rank():
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert packages == set(RANKS)


# The checker itself must catch what it is for.
@pytest.mark.parametrize("deps, expected", [
    ({"tpuaf.runtimes.physics": {"tpuaf.cli.fleet"}, "tpuaf.cli.fleet": set()},
     ["tpuaf.runtimes.physics imports tpuaf.cli.fleet: nothing outside cli/ may"]),
    ({"tpuaf.maps.model": {"tpuaf.measure.metrics"}, "tpuaf.measure.metrics": set()},
     ["tpuaf.maps.model (maps) imports tpuaf.measure.metrics (measure), a higher layer"]),
    ({"tpuaf.topics": {"tpuaf.team.messages"}, "tpuaf.team.messages": set()},
     ["tpuaf.topics (top) imports tpuaf.team.messages (team), a higher layer"]),
    ({"tpuaf.runtimes.graph": {"tpuaf.maps.model"}, "tpuaf.maps.model": set()}, []),
])
def test_the_checker_finds_upward_imports(deps, expected):
    assert violations(deps) == expected


def test_the_checker_finds_circles():
    deps = {"tpuaf.experiments.results": {"tpuaf.experiments.plots"},
            "tpuaf.experiments.plots": {"tpuaf.experiments.report"},
            "tpuaf.experiments.report": {"tpuaf.experiments.results"},
            "tpuaf.maps.model": set()}
    assert cycles(deps) == [["tpuaf.experiments.plots", "tpuaf.experiments.report",
                             "tpuaf.experiments.results"]]


def test_function_level_imports_count(tmp_path):
    pkg = tmp_path / "tpuaf"
    (pkg / "runtimes").mkdir(parents=True)
    (pkg / "cli").mkdir()
    for p in (pkg, pkg / "runtimes", pkg / "cli"):
        (p / "__init__.py").write_text("")
    (pkg / "cli" / "fleet.py").write_text("X = 1\n")
    (pkg / "runtimes" / "physics.py").write_text(
        "def f():\n    from ..cli.fleet import X\n    return X\n")
    global PACKAGE
    saved, PACKAGE = PACKAGE, pkg
    try:
        deps = graph(pkg)
    finally:
        PACKAGE = saved
    assert "tpuaf.cli.fleet" in deps["tpuaf.runtimes.physics"]
