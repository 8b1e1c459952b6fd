"""The launch files describe themselves: `roslaunch --ros-args` lists every arg with its doc (no
master needed) and only the truly required ones as required, units and choices are in the docs,
the launch arg map_params reaches every node that loads the map (`roslaunch --dump-params`), and
no launch file sets a global parameter it does not own (the fleet owns the simulated clock:
/use_sim_time)."""

from __future__ import annotations

import re
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from .conftest import REPO, workspace_env

pytestmark = pytest.mark.ros

LAUNCH_DIR = REPO / "src/tpuaf_ros/launch"
LAUNCH_FILES = ("fleet.launch", "robot.launch", "robots.launch", "rviz.launch")
# Global parameters a launch file may set because it owns them.
OWNED_GLOBALS = {"fleet.launch": {"/use_sim_time"}}
# The args a launch file cannot run without; every other arg has a real default.
REQUIRED = {"fleet.launch": {"out"}, "robot.launch": set(), "rviz.launch": set(),
            "robots.launch": {"n", "robots", "map"}}  # robots.launch: included by fleet.launch
# An arg whose name has one of these words has a unit, written "[unit]" in its doc.
UNIT_WORDS = ("timeout", "delay", "duration", "speed", "radius", "scale", "offset")


def declared_args(name: str) -> dict[str, ET.Element]:
    """The <arg> tags a user can set: those without value= (roslaunch lists the same)."""
    root = ET.parse(LAUNCH_DIR / name).getroot()
    return {a.get("name"): a for a in root.iter("arg") if a.get("value") is None
            and a.get("name") is not None}


def ros_args(name: str, tmp_path: Path) -> subprocess.CompletedProcess:
    env = {**workspace_env(), "ROS_MASTER_URI": "http://127.0.0.1:9/",  # nothing listens there
           "ROS_HOME": str(tmp_path), "ROS_IP": "127.0.0.1"}
    env.pop("ROS_HOSTNAME", None)
    return subprocess.run(["roslaunch", "--ros-args", "tpuaf_ros", name], env=env,
                          capture_output=True, text=True, timeout=120, start_new_session=True)


def test_the_launch_folder_holds_the_files_tested_here():
    assert sorted(p.name for p in LAUNCH_DIR.glob("*.launch")) == sorted(LAUNCH_FILES)


@pytest.mark.parametrize("name", LAUNCH_FILES)
def test_ros_args_lists_every_arg_with_its_doc_without_a_master(name, tmp_path):
    proc = ros_args(name, tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "undocumented" not in proc.stdout, proc.stdout
    listed = {}
    for line in proc.stdout.splitlines():
        m = re.match(r"^  (\w+)(?: \(default \"(.*)\"\))?: (.*)$", line)
        if m:
            listed[m.group(1)] = m.group(3)
    args = declared_args(name)
    assert set(listed) == set(args), proc.stdout
    for arg, doc in listed.items():
        assert doc.strip() and doc == args[arg].get("doc"), (arg, doc)
    required = proc.stdout.split("Optional Arguments:")[0]
    assert set(re.findall(r"^  (\w+): ", required, re.M)) == REQUIRED[name], proc.stdout


def dump_params(name: str, tmp_path: Path, *args: str) -> dict:
    """The parameters launch file `name` sets with `args` (roslaunch --dump-params, no master)."""
    import yaml

    env = {**workspace_env(), "ROS_MASTER_URI": "http://127.0.0.1:9/",
           "ROS_HOME": str(tmp_path), "ROS_IP": "127.0.0.1"}
    proc = subprocess.run(["roslaunch", "--dump-params", "tpuaf_ros", name, *args], env=env,
                          capture_output=True, text=True, timeout=120, start_new_session=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return yaml.safe_load(proc.stdout)


MAP_PARAMS = "{sensing_radius: 2.0, growth_coefficients: [1.0, 0.3]}"


@pytest.mark.parametrize("name, args, nodes", [
    ("fleet.launch", ["out:=/tmp/unused", "robots:=2"],
     ["/monitor", "/robot_0/patrol_agent", "/robot_1/patrol_agent"]),
    ("robot.launch", ["index:=1", "robots:=2"], ["/robot_1/patrol_agent"]),
    ("rviz.launch", [], ["/patrol_markers"]),
])
def test_launch_arg_map_params_reaches_every_node_that_loads_the_map(name, args, nodes,
                                                                     tmp_path):
    """The launch-level override of the map's settings (docs/MAPS.md: map < launch): each node
    gets ~map_params, which it applies over the map's own (tests/test_map_params.py)."""
    from tpuaf.maps import load_map

    params = dump_params(name, tmp_path, *args, f"map_params:={MAP_PARAMS}")
    for node in nodes:
        given = {"sensing_radius": params[f"{node}/map_params/sensing_radius"],
                 "growth_coefficients": params[f"{node}/map_params/growth_coefficients"]}
        assert given == {"sensing_radius": 2.0, "growth_coefficients": [1.0, 0.3]}, node
        pm = load_map("lab", params=given, params_origin="~map_params")
        assert pm.settings.sensing_radius == 2.0 and pm.settings.sensing_radius != \
            load_map("lab").settings.sensing_radius
    plain = dump_params(name, tmp_path, *args)
    assert not any("map_params" in key for key in plain)  # {}: the nodes' default, the map's


@pytest.mark.parametrize("name", LAUNCH_FILES)
def test_every_arg_has_a_doc_with_its_unit_and_choices(name):
    from tpuaf.measure.markers import MODES
    from tpuaf.measure.poses import POSE_SOURCES
    from tpuaf.policies import REGISTRY
    from tpuaf.runtimes.agent_setup import LOCALIZATIONS

    choices = {"localization": LOCALIZATIONS, "pose_source": tuple(POSE_SOURCES),
               "color_by": MODES, "navigation": ("builtin", "move_base"),
               "output": ("log", "screen")}
    for arg, tag in declared_args(name).items():
        doc = (tag.get("doc") or "").strip()
        assert doc, f"{name}: <arg name={arg!r}> has no doc"
        if any(word in arg for word in UNIT_WORDS):
            assert re.search(r"\[[^\]]+\]", doc), f"{name}: {arg}: no [unit] in {doc!r}"
        if tag.get("default") in ("true", "false"):
            assert "true | false" in doc, f"{name}: {arg}: {doc!r}"
        for choice in choices.get(arg, ()):
            assert re.search(rf"\b{choice}\b", doc), f"{name}: {arg}: {choice} not in {doc!r}"
        if arg == "strategy":
            named = set(re.findall(r"\w+", doc))
            assert "tpuaf run --list" in doc or set(REGISTRY.names()) <= named, (name, doc)
        # roslaunch lists an empty default under "Required Arguments": an optional arg has a
        # real one (none, auto, {}) that its doc explains
        assert tag.get("default") != "", f"{name}: {arg}: empty default"


def global_params(path: Path) -> list[str]:
    """Names of the global parameters a launch file sets: <param>/<rosparam> outside any node
    and namespace, or with an absolute name anywhere."""
    found: list[str] = []

    def walk(elem: ET.Element, ns: str, in_node: bool) -> None:
        for child in elem:
            if child.tag == "group":
                inner = child.get("ns") or ""
                walk(child, inner if inner.startswith("/") else f"{ns}/{inner}", in_node)
            elif child.tag == "node":
                walk(child, ns, True)
            elif child.tag in ("param", "rosparam"):
                pname = child.get("name") if child.tag == "param" else child.get("param")
                pname = pname or child.get("ns") or ""
                if pname.startswith("/"):
                    found.append(pname)
                elif not in_node and ns.strip("/") == "":
                    found.append(f"/{pname}")

    walk(ET.parse(path).getroot(), "", False)
    return found


@pytest.mark.parametrize("name", LAUNCH_FILES)
def test_no_launch_file_sets_a_global_it_does_not_own(name):
    owned = OWNED_GLOBALS.get(name, set())
    assert set(global_params(LAUNCH_DIR / name)) <= owned, (name, global_params(LAUNCH_DIR / name))


def test_the_fleet_sets_sim_time_it_owns_the_simulated_clock():
    """`tpuaf fleet` relies on it: the agents and the monitor run on the simulator's /clock."""
    root = ET.parse(LAUNCH_DIR / "fleet.launch").getroot()
    sim = [p for p in root.findall("param") if p.get("name") == "/use_sim_time"]
    assert [p.get("value") for p in sim] == ["true"]
    assert global_params(LAUNCH_DIR / "rviz.launch") == []  # the viewer leaves the clock alone


def test_the_global_param_check_finds_a_global(tmp_path):
    """The checker itself: a top-level relative <param> and an absolute one are globals; one in
    a node or in a namespaced group is not."""
    (tmp_path / "x.launch").write_text(
        '<launch><param name="use_sim_time" value="true"/>'
        '<group ns="r"><param name="a" value="1"/></group>'
        '<node pkg="p" type="t" name="n"><param name="b" value="1"/>'
        '<param name="/c" value="1"/></node></launch>')
    assert global_params(tmp_path / "x.launch") == ["/use_sim_time", "/c"]


def test_fleet_md_shows_the_fleet_args_as_ros_args_prints_them(tmp_path):
    proc = ros_args("fleet.launch", tmp_path)
    assert proc.returncode == 0, proc.stderr
    doc = (REPO / "docs/FLEET.md").read_text()
    block = "\n".join("  " + line for line in proc.stdout.strip().splitlines())
    assert block in doc, "docs/FLEET.md: paste `roslaunch tpuaf_ros fleet.launch --ros-args`"
    assert "launch_scripts/fleet.launch" not in doc and "launch_scripts/robot" not in doc
