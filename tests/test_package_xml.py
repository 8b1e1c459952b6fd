"""Every package.xml declares what its code imports, with its rosdep key, so that
`rosdep install --from-paths src` can prepare a robot: each third-party module imported anywhere
in a package's Python (function-level imports too) or included by its C++ maps to a declared key."""

from __future__ import annotations

import ast
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src"

# Python top-level module -> rosdep key (Debian: python3-*, ROS: the package's own name).
PYTHON_KEYS = {
    "numpy": "python3-numpy", "yaml": "python3-yaml", "networkx": "python3-networkx",
    "matplotlib": "python3-matplotlib", "tqdm": "python3-tqdm", "PIL": "python3-pil",
    "scipy": "python3-scipy",
    "dask": "python3-dask", "distributed": "python3-dask",
    "rospy": "rospy", "rosbag": "rosbag", "roslaunch": "roslaunch", "rosgraph": "rospy",
    "genpy": "rospy", "actionlib": "actionlib", "tf2_ros": "tf2_ros",
}
# Modules that are ROS message packages: their key is their name.
MESSAGE_SUFFIX = "_msgs"
# PyPI only (no rosdep key): named in a comment of the package.xml and in requirements.txt.
PYPI_ONLY = {"rosbags", "pytest", "hypothesis"}
OURS = {"tpuaf", "tpuaf_core", "tpuaf_ros", "tpuaf_stage"}
# C++ include prefix -> rosdep key.
CPP_KEYS = {"ros/": "roscpp", "Eigen/": "eigen", "fcl/": "libfcl-dev", "pybind11/": "pybind11-dev",
            "yaml-cpp/": "yaml-cpp", "topic_tools/": "topic_tools", "std_srvs/": "std_srvs",
            "gtest/": "gtest"}


def declared(package_xml: Path) -> set[str]:
    root = ET.parse(package_xml).getroot()
    return {el.text.strip() for el in root if el.tag.endswith("depend") and el.text}


def python_imports(folder: Path) -> set[str]:
    names = set()
    for path in folder.rglob("*.py"):
        if path.name == "setup.py":  # catkin's build tooling (catkin_pkg, setuptools)
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names.update(a.name.split(".")[0] for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                names.add(node.module.split(".")[0])
    return {n for n in names if n not in sys.stdlib_module_names and n not in OURS}


def cpp_includes(folder: Path) -> set[str]:
    found = set()
    for path in [*folder.rglob("*.cpp"), *folder.rglob("*.hpp"), *folder.rglob("*.h")]:
        found.update(re.findall(r"^#include <([^>]+)>", path.read_text(), re.M))
    return found


def rosdep_key(module: str) -> str | None:
    if module in PYTHON_KEYS:
        return PYTHON_KEYS[module]
    if module.endswith(MESSAGE_SUFFIX):
        return module
    return None


@pytest.mark.parametrize("package", ["tpuaf_ros", "tpuaf_core_cpp", "tpuaf_stage"])
def test_every_import_has_a_declared_rosdep_key(package):
    folder = SRC / package
    keys = declared(folder / "package.xml")
    missing, unknown = [], []
    for module in sorted(python_imports(folder) - PYPI_ONLY):
        key = rosdep_key(module)
        if key is None:
            unknown.append(module)
        elif key not in keys:
            missing.append(f"{module} ({key})")
    for include in sorted(cpp_includes(folder)):
        prefix = next((p for p in CPP_KEYS if include.startswith(p)), None)
        head = include.split("/")[0]
        key = CPP_KEYS[prefix] if prefix else (head if head.endswith(MESSAGE_SUFFIX) else None)
        if key is not None and key not in keys and head not in OURS and head != "tpuaf_core":
            missing.append(f"<{include}> ({key})")
    assert not unknown, f"{package}: imports with no known rosdep key: {unknown}"
    assert not missing, f"{package}/package.xml does not declare: {missing}"


def test_the_scan_finds_an_undeclared_import(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("def f():\n    import actionlib\n    from nav_msgs.msg import Odometry\n")
    (pkg / "package.xml").write_text("<package><exec_depend>nav_msgs</exec_depend></package>")
    modules = python_imports(pkg)
    assert modules == {"actionlib", "nav_msgs"}
    assert {rosdep_key(m) for m in modules} - declared(pkg / "package.xml") == {"actionlib"}
