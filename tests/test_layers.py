"""The layers (docs/DEVELOPING.md): one dependency direction, no import circle, ROS where it
belongs, and packages that import only what their package.xml declares.

1. Inside `tpuaf`: cli -> experiments -> runtimes -> robot -> team / navigation / measure /
   policies -> maps -> the plumbing at the top (errors, params, topics, paths, plain, files).
   `ros/` (the rospy adapters) sits beside `cli/`; nothing imports either of them.
2. ROS client code (rospy, rosbag, roslaunch, actionlib, tf2_ros, message packages, ...) is
   imported only by `tpuaf/ros/` and the fleet supervisor `tpuaf/cli/fleet*.py`; the Python
   packages beside tpuaf (tpuaf_stage, tpuaf_core) import none.
3. A Python package imports another catkin package's Python (tpuaf_stage -> tpuaf, tpuaf ->
   tpuaf_stage, ...) only when its package.xml declares that package as a run dependency and
   catkin's order of the workspace has no circle.

Every import counts, function-level ones included, and importlib.import_module of a literal.
"""

from __future__ import annotations

import ast
import fnmatch
import shutil
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src"
PACKAGE = SRC / "tpuaf_ros" / "src" / "tpuaf"

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

# ROS client code: the ROS Python libraries and message packages (a root ending in _msgs or
# _srvs, or naming a catkin package of this workspace with msg/ or srv/: tpuaf_ros.msg). Any
# other root starting with "ros" counts too, except rosbags (PyPI: reads bag files, no ROS).
ROS_ROOTS = frozenset({
    "rospy", "rosbag", "roslaunch", "rosgraph", "rosnode", "rosparam", "rosservice", "rostopic",
    "rosmsg", "rosmaster", "roslib", "rospkg", "rostest", "rosunit", "roscpp", "genpy", "genmsg",
    "actionlib", "tf", "tf2_ros", "tf2_py", "tf_conversions", "message_filters", "topic_tools",
    "dynamic_reconfigure", "interactive_markers", "catkin",
})
NOT_ROS = frozenset({"rosbags"})
# Modules (fnmatch patterns) that may import ROS client code, per Python package; a package
# not named here imports none.
ROS_ALLOWED = {"tpuaf": ("tpuaf.ros", "tpuaf.ros.*", "tpuaf.cli.fleet*")}


# ---------------------------------------------------------------------------------------------
# Reading imports


def imports_in(source: str, module: str, is_package: bool = False) -> set[str]:
    """Every module that `source` (the text of `module`) imports, at any depth of the code:
    absolute names (relative ones resolved); `from m import a` gives m and m.a (a may be a
    module); importlib.import_module / __import__ of a literal name (an f-string: the
    package before its first field)."""
    me = module.split(".")
    package = me if is_package else me[:-1]
    found: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            found.add(name)
            found.update(f"{name}.{a.name}" for a in node.names if a.name != "*")
        elif isinstance(node, ast.Call) and node.args and _is_dynamic_import(node.func):
            name = _literal_module(node.args[0])
            if name:
                found.add(name)
    return found


def _is_dynamic_import(func: ast.expr) -> bool:
    if isinstance(func, ast.Attribute):
        return func.attr == "import_module"
    return isinstance(func, ast.Name) and func.id in ("import_module", "__import__")


def _literal_module(arg: ast.expr) -> str:
    if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
        return arg.value
    if isinstance(arg, ast.JoinedStr) and arg.values and isinstance(arg.values[0], ast.Constant):
        return str(arg.values[0].value).rpartition(".")[0]
    return ""


def module_name(path: Path, root: Path) -> str:
    """The dotted name of the module at `path`, `root` being the folder its package sits in."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def module_imports(package: Path) -> dict[str, set[str]]:
    """Module name -> every module it imports, for each module of the Python package folder."""
    out = {}
    for path in sorted(package.rglob("*.py")):
        name = module_name(path, package.parent)
        out[name] = imports_in(path.read_text(encoding="utf-8"), name,
                               path.name == "__init__.py")
    return out


# ---------------------------------------------------------------------------------------------
# 1. Layers inside tpuaf


def graph(package: Path = PACKAGE) -> dict[str, set[str]]:
    """Module -> the modules of the same package it imports."""
    imports = module_imports(package)
    return {name: {m for m in found if m in imports and m != name}
            for name, found in imports.items()}


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


# ---------------------------------------------------------------------------------------------
# 2. ROS client code


def message_packages(src: Path = SRC) -> set[str]:
    """Catkin packages of the workspace that generate messages or services."""
    return {p.parent.name for p in src.glob("*/package.xml")
            if (p.parent / "msg").is_dir() or (p.parent / "srv").is_dir()}


def is_ros(module: str, messages: frozenset[str] | set[str] = frozenset()) -> bool:
    root = module.split(".")[0]
    if root in NOT_ROS:
        return False
    return (root in ROS_ROOTS or root in messages or root.endswith(("_msgs", "_srvs"))
            or root.startswith("ros"))


def ros_violations(imports: dict[str, set[str]], messages: frozenset[str] | set[str] = frozenset()
                   ) -> list[str]:
    """ROS client imports of modules that may not import them (ROS_ALLOWED)."""
    found = set()
    for module, imported in imports.items():
        allowed = ROS_ALLOWED.get(module.split(".")[0], ())
        if any(fnmatch.fnmatchcase(module, pattern) for pattern in allowed):
            continue
        for name in imported:
            if is_ros(name, messages):
                where = (" or ".join(allowed) if allowed else "no module of "
                         + module.split(".")[0])
                found.add(f"{module} imports {name.split('.')[0]}: ROS client code belongs "
                          f"in {where}")
    return sorted(found)


# ---------------------------------------------------------------------------------------------
# 3. Packages beside tpuaf


def python_packages(src: Path = SRC) -> dict[str, tuple[str, Path]]:
    """Top-level Python package -> (the catkin package holding it, its folder)."""
    out = {}
    for xml in sorted(src.glob("*/package.xml")):
        for init in sorted(xml.parent.rglob("__init__.py")):
            folder = init.parent
            if not (folder.parent / "__init__.py").is_file() and "test" not in folder.parts:
                out[folder.name] = (xml.parent.name, folder)
    return out


def run_depends(package_xml: Path) -> set[str]:
    from catkin_pkg.package import parse_package

    pkg = parse_package(str(package_xml))
    return {d.name for d in [*pkg.exec_depends, *pkg.run_depends]}


def catkin_circle(src: Path) -> str | None:
    """catkin's order of the workspace's packages (build, buildtool and test dependencies, and
    the run dependencies of those): None, or what it says of a circle."""
    from catkin_pkg.topological_order import topological_order

    stuck = [str(what) for path, what in topological_order(str(src)) if path is None]
    return ", ".join(stuck) or None


def package_violations(src: Path = SRC) -> list[str]:
    """Imports of another catkin package's Python that the importer's package.xml does not
    declare as a run dependency, and a circle in catkin's order."""
    packages = python_packages(src)
    owner = {name: catkin for name, (catkin, _) in packages.items()}
    owner.update({m: m for m in message_packages(src)})
    found = set()
    for catkin, folder in packages.values():
        declared = run_depends(src / catkin / "package.xml")
        for module, imported in module_imports(folder).items():
            for other in imported:
                theirs = owner.get(other.split(".")[0])
                if theirs not in (None, catkin) and theirs not in declared:
                    found.add(f"{module} imports {other.split('.')[0]}: {catkin}/package.xml "
                              f"does not declare {theirs} (exec_depend)")
    circle = catkin_circle(src)
    if circle:
        found.add(f"catkin's order has a circle through: {circle}")
    return sorted(found)


def all_module_imports(src: Path = SRC) -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for _, folder in python_packages(src).values():
        out.update(module_imports(folder))
    return out


# ---------------------------------------------------------------------------------------------
# The tree


def test_every_import_goes_down_the_layers():
    assert violations(graph()) == []


def test_no_import_circle():
    assert cycles(without_parent_packages(graph())) == []


def test_every_sub_package_has_a_rank():
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert packages == set(RANKS)


def test_only_ros_and_the_fleet_supervisor_import_ros_client_code():
    assert ros_violations(all_module_imports(), message_packages()) == []


def test_packages_import_only_declared_packages_in_catkin_order():
    assert set(python_packages()) >= {"tpuaf", "tpuaf_stage", "tpuaf_core"}
    assert package_violations() == []


def test_tpuaf_stage_uses_tpuaf_in_map_sources_only():
    """The one seam of the declared tpuaf_stage -> tpuaf_ros dependency (world files naming a
    map); the presets, the world model and resolved world files need only tpuaf_core."""
    _, folder = python_packages()["tpuaf_stage"]
    users = {m for m, imported in module_imports(folder).items()
             if any(name.split(".")[0] == "tpuaf" for name in imported)}
    assert users == {"tpuaf_stage.map_sources"}


def test_the_ros_rule_knows_every_ros_import_of_the_adapters():
    """What tpuaf/ros/ imports beyond the standard library, our packages and the plain Python
    libraries is ROS: the rule's list misses none of it."""
    plain = {"numpy", "yaml", "scipy", "matplotlib", "networkx", "PIL", "tqdm", "dask",
             "distributed"}
    ours = set(python_packages())
    roots = {name.split(".")[0] for imported in module_imports(PACKAGE / "ros").values()
             for name in imported}
    others = roots - set(sys.stdlib_module_names) - ours - plain - {""}
    assert others and all(is_ros(r, message_packages()) for r in others), others


# ---------------------------------------------------------------------------------------------
# The checkers themselves must catch what they are for.


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
    (pkg / "runtimes" / "graph.py").write_text(
        "class A:\n    def f(self):\n        if True:\n            import tpuaf.cli.fleet\n")
    deps = graph(pkg)
    assert "tpuaf.cli.fleet" in deps["tpuaf.runtimes.physics"]
    assert "tpuaf.cli.fleet" in deps["tpuaf.runtimes.graph"]
    assert len(violations(deps)) == 2


@pytest.mark.parametrize("module, source, reported", [
    ("tpuaf.measure.monitor", "import rospy\n", "rospy"),
    ("tpuaf.runtimes.agent", "def f():\n    import rospy\n", "rospy"),  # function level
    ("tpuaf.cli.run", "class A:\n    def f(self):\n        from rosbag import Bag\n", "rosbag"),
    ("tpuaf.maps", "from std_msgs.msg import Float64\n", "std_msgs"),
    ("tpuaf.measure.metrics", "def f():\n    from tpuaf_ros.msg import AgentEvent\n",
     "tpuaf_ros"),
    ("tpuaf.navigation.frames", "import tf2_ros.buffer as b\n", "tf2_ros"),
    ("tpuaf.runtimes.graph", "import importlib\nimportlib.import_module('roslaunch')\n",
     "roslaunch"),
    ("tpuaf.cli.compare", "from rosservice import call\n", "rosservice"),  # a "ros" root
    ("tpuaf_stage.config", "def f():\n    import rospy\n", "rospy"),
    ("tpuaf_core.yamlfile", "import genpy\n", "genpy"),
])
def test_the_ros_checker_finds_ros_imports_outside_ros(module, source, reported):
    imports = {module: imports_in(source, module)}
    found = ros_violations(imports, {"tpuaf_ros"})
    assert len(found) == 1 and found[0].startswith(f"{module} imports {reported}: "), found


@pytest.mark.parametrize("module", ["tpuaf.ros.agent_node", "tpuaf.ros", "tpuaf.cli.fleet",
                                    "tpuaf.cli.fleet_supervisor", "tpuaf.cli.fleet_ros"])
def test_the_ros_checker_lets_ros_and_the_fleet_supervisor_import_ros(module):
    source = "import rospy\nfrom std_msgs.msg import Float64\nfrom tpuaf_ros.msg import A\n"
    assert ros_violations({module: imports_in(source, module)}, {"tpuaf_ros"}) == []


def test_rosbags_is_not_ros_client_code():
    source = "def f():\n    from rosbags.rosbag1 import Reader\n"
    assert ros_violations({"tpuaf.measure.bag": imports_in(source, "tpuaf.measure.bag")}) == []


def _workspace(tmp_path: Path, stage_source: str, stage_xml: str | None = None) -> Path:
    """A copy of the workspace's package.xml files with tiny tpuaf, tpuaf_stage and tpuaf_core
    Python packages; tpuaf_stage/config.py holds `stage_source`."""
    src = tmp_path / "src"
    for xml in SRC.glob("*/package.xml"):
        (src / xml.parent.name).mkdir(parents=True)
        shutil.copy(xml, src / xml.parent.name / "package.xml")
    (src / "tpuaf_ros" / "msg").mkdir()
    for folder in ("tpuaf_ros/src/tpuaf", "tpuaf_ros/src/tpuaf/maps", "tpuaf_stage/src/tpuaf_stage",
                   "tpuaf_core_cpp/python/tpuaf_core"):
        (src / folder).mkdir(parents=True)
        (src / folder / "__init__.py").write_text("")
    (src / "tpuaf_ros/src/tpuaf/maps/model.py").write_text("import tpuaf_stage\nimport tpuaf_core\n")
    (src / "tpuaf_stage/src/tpuaf_stage/config.py").write_text(stage_source)
    if stage_xml is not None:
        (src / "tpuaf_stage" / "package.xml").write_text(stage_xml)
    return src


UNDECLARED = "def parse_world(doc):\n    from tpuaf.maps import load_map\n    return load_map\n"


def test_the_package_checker_finds_an_undeclared_tpuaf_stage_to_tpuaf_import(tmp_path):
    xml = (SRC / "tpuaf_stage" / "package.xml").read_text()
    without = xml.replace("<exec_depend>tpuaf_ros</exec_depend>", "")
    assert "tpuaf_ros</" not in without
    src = _workspace(tmp_path, UNDECLARED, without)
    assert package_violations(src) == [
        "tpuaf_stage.config imports tpuaf: tpuaf_stage/package.xml does not declare tpuaf_ros "
        "(exec_depend)"]
    # the same with the import at the top, and with its messages (tpuaf_ros.msg)
    for source in ("import tpuaf.maps\n", "from tpuaf_ros.msg import AgentEvent\n"):
        (src / "tpuaf_stage/src/tpuaf_stage/config.py").write_text(source)
        assert len(package_violations(src)) == 1


def test_the_package_checker_accepts_a_declared_run_dependency_and_nothing_more(tmp_path):
    xml = (SRC / "tpuaf_stage" / "package.xml").read_text()
    without = xml.replace("<exec_depend>tpuaf_ros</exec_depend>", "")
    declared = without.replace("</package>", "  <exec_depend>tpuaf_ros</exec_depend>\n</package>")
    assert package_violations(_workspace(tmp_path / "a", UNDECLARED, declared)) == []
    # tpuaf_stage without a tpuaf import needs no declaration
    assert package_violations(_workspace(tmp_path / "b", "import tpuaf_core\n", without)) == []


def test_the_package_checker_finds_a_circle_in_catkins_order(tmp_path):
    """A build dependency of tpuaf_stage on tpuaf_ros (which runs tpuaf_stage) is a circle."""
    xml = (SRC / "tpuaf_stage" / "package.xml").read_text()
    without = xml.replace("<exec_depend>tpuaf_ros</exec_depend>", "")
    circle = without.replace("</package>", "  <depend>tpuaf_ros</depend>\n</package>")
    found = package_violations(_workspace(tmp_path, UNDECLARED, circle))
    assert found == ["catkin's order has a circle through: tpuaf_stage"]


def test_the_package_checker_reads_function_level_and_dynamic_imports():
    source = ("import importlib\n\ndef f():\n    if True:\n        from .x import y\n"
              "    return importlib.import_module(f'tpuaf.cli.{y}')\n")
    found = imports_in(source, "tpuaf_stage.config")
    assert {"tpuaf_stage.x", "tpuaf_stage.x.y", "tpuaf.cli"} <= found
