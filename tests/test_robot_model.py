"""One robot model, chosen once, from the CLI, the launch args or TURTLEBOT3_MODEL, reaching every
consumer: the controller, the world, the strategies (the plan's speed and travel times), the
recorder, config.yaml and the graph runtime (issue 32, part 1)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from tpuaf.maps import load_map
from tpuaf.navigation.planner import shared_planner
from tpuaf.navigation.travel_time import edge_durations
from tpuaf.params import AgentParams
from tpuaf.robot.model import ENV_VAR, RobotChoiceError, choose_robot
from tpuaf.runtimes.config import ConfigError, PhysicsConfig, RunConfig
from tpuaf.runtimes.graph import make_run
from tpuaf.runtimes.physics import PhysicsRun

TPUAF = str(Path(sys.executable).with_name("tpuaf"))
LAUNCH = Path(__file__).resolve().parents[1] / "src" / "tpuaf_ros" / "launch"
GRID = load_map("grid")  # 1 m/s map


# ---------------------------------------------------------------------------------------------
# The choice


def test_the_environment_variable_chooses_when_the_option_says_auto():
    waffle = choose_robot("auto", GRID.settings, env={ENV_VAR: "waffle"})
    assert (waffle.preset, waffle.source, waffle.speed_mps) == ("waffle", ENV_VAR, 0.26)
    assert waffle.max_angular_speed == 1.82
    # An explicit preset wins over the environment; without either, the map's preset.
    assert choose_robot("burger", GRID.settings, env={ENV_VAR: "waffle"}).preset == "burger"
    plain = choose_robot(None, GRID.settings, env={})
    assert (plain.preset, plain.source) == ("patrolling_sim", "auto")


def test_an_unknown_environment_value_names_the_variable():
    with pytest.raises(RobotChoiceError, match=f"environment variable {ENV_VAR}: unknown robot "
                                               "preset 'tb4'"):
        choose_robot("auto", GRID.settings, env={ENV_VAR: "tb4"})


def test_the_speed_is_the_maps_capped_at_the_preset():
    lab = load_map("lab").settings  # 0.1 m/s: slower than any preset
    assert choose_robot("burger", lab, env={}).speed_mps == 0.1
    burger = choose_robot("burger", GRID.settings, env={})
    assert burger.speed_mps == 0.22 and burger.max_speed_mps == 0.22 and burger.note


# ---------------------------------------------------------------------------------------------
# Every consumer in the runtimes


def test_graph_runtime_plans_and_drives_at_the_robots_speed():
    run = make_run(RunConfig(map="grid", strategy="tpuaf_plus", robots=2, duration_s=120,
                             robot="burger"))
    assert run.robot.preset == "burger" and run.config.resolved_travel() == "timed"
    # The plan's map: the robot's speed, each edge's length its travel time at that speed.
    assert run.patrol_map.settings.nominal_speed == 0.22 and run.speed == 0.22
    # Each effective length is 0.22 m/s x the travel-time model's duration of the edge, and a
    # modelled traversal is never quicker than driving the straight line at top speed.
    durations = edge_durations(GRID, run.robot, shared_planner(GRID, run.robot.radius_m))
    xy = GRID.positions
    for i, j, length in run.patrol_map.edges:
        assert length == pytest.approx(0.22 * durations[(int(i), int(j))])
        straight = float(((xy[i] - xy[j]) ** 2).sum() ** 0.5)
        assert length > straight - 2 * GRID.settings.goal_tolerance
    summary = run.run()
    assert run.recorder.speed_mps == 0.22
    config = run.effective_config()
    assert config["robot_model"]["preset"] == "burger" and config["robot"] == "burger"
    # Moving from one vertex to another takes at least the shortest modelled traversal (an
    # edge's mean, or its time for one way of arriving: straight on is quicker).
    turns = run.patrol_map.turns
    assert turns and all(math.isfinite(s) for s in turns.values())
    shortest_s = min(min(durations.values()),
                     min(durations[min(u, v), max(u, v)] + s for (_, u, v), s in turns.items()))
    last: dict[int, tuple[float, int]] = {}
    moves = 0
    for t, robot, vertex in run.recorder.visits:
        if robot in last and last[robot][1] != vertex:
            assert t - last[robot][0] >= shortest_s - 1e-6
            moves += 1
        last[robot] = (t, vertex)
    assert summary["visits"] >= moves >= 4  # both robots left their start and moved on


def test_graph_runtime_without_a_robot_keeps_the_maps_figures():
    run = make_run(RunConfig(map="grid", robots=2, duration_s=60))
    assert run.robot is None and run.patrol_map is run.source_map
    assert run.config.resolved_travel() == "declared"


def test_physics_runtime_gives_one_model_to_controller_world_policies_and_recorder():
    run = PhysicsRun(PhysicsConfig(map="grid", strategy="tpuaf", robots=2, duration_s=5,
                                   robot="waffle"))
    assert run.robot.preset == "waffle"
    spec = run.world.robot_spec(0)
    assert spec.radius_m == pytest.approx(0.153)
    for agent in run.agents:
        c = agent.navigator.controller.config
        assert (c.max_linear_speed, c.max_angular_speed, c.robot_radius) == (0.26, 1.82, 0.153)
        assert agent.machine.patrol_map.settings.nominal_speed == 0.26  # the strategy's plan
    assert run.recorder.speed_mps == 0.26
    assert run.effective_config()["robot_model"]["preset"] == "waffle"


def test_a_bad_robot_is_a_config_error():
    with pytest.raises(ConfigError, match="unknown robot preset 'tank'"):
        make_run(RunConfig(map="grid", robots=2, duration_s=60, robot="tank"))


# ---------------------------------------------------------------------------------------------
# The CLI, the launch files and the environment


def test_run_robot_flag_reaches_config_yaml_in_the_graph_runtime(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.run([TPUAF, "run", "--robots", "2", "--duration", "60", "--quiet",
                           "--no-plots", "--robot", "burger", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    config = yaml.safe_load((out / "config.yaml").read_text())
    assert config["robot"] == "burger" and config["robot_model"]["speed_mps"] == 0.22
    assert config["map_settings"]["nominal_speed"] == 0.22  # what the strategies planned with


def test_run_reads_turtlebot3_model_for_auto(tmp_path):
    out = tmp_path / "run"
    env = {**__import__("os").environ, ENV_VAR: "waffle_pi"}
    proc = subprocess.run([TPUAF, "run", "--robots", "2", "--duration", "30", "--quiet",
                           "--no-plots", "--robot", "auto", "--out", str(out)],
                          capture_output=True, text=True, timeout=300, env=env)
    assert proc.returncode == 0, proc.stderr
    model = yaml.safe_load((out / "config.yaml").read_text())["robot_model"]
    assert (model["preset"], model["source"]) == ("waffle_pi", ENV_VAR)


def test_bad_robot_flag_is_a_one_line_error(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.run([TPUAF, "run", "--robot", "tank", "--duration", "30", "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "tank" in proc.stderr


def test_fleet_passes_the_chosen_preset_to_agents_and_simulator(tmp_path):
    out = tmp_path / "fleet"
    proc = subprocess.run([TPUAF, "fleet", "--prepare-only", "--duration", "60", "--robot",
                           "burger", "--out", str(out)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert " robot:=burger" in proc.stdout, proc.stdout
    config = yaml.safe_load((out / "fleet_config.yaml").read_text())
    assert config["robot"]["preset"] == "burger" and config["robot"]["speed_mps"] == 0.22
    world = yaml.safe_load((out / "world.yaml").read_text())
    assert world["robot"] == {"preset": "burger", "max_linear_speed": 0.22}


def _launch_params(args: list[str]) -> dict:
    """The parameters robot.launch sets, as roslaunch resolves them (no master needed)."""
    code = ("import sys, json, roslaunch.config as c\n"
            "cfg = c.load_config_default([sys.argv[1]], None)  # args: name:=value in argv\n"
            "print(json.dumps({k: v.value for k, v in cfg.params.items()}))")
    proc = subprocess.run([sys.executable, "-c", code, str(LAUNCH / "robot.launch"), *args],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("args, env, preset, speed", [
    (["robot:=burger"], {}, "burger", 0.22),
    ([], {ENV_VAR: "waffle"}, "waffle", 0.26),
    ([], {}, "patrolling_sim", 1.0),
])
def test_robot_launch_reaches_the_agents_model(args, env, preset, speed, monkeypatch):
    from tpuaf.runtimes.agent_setup import agent_robot

    params = _launch_params(["map:=grid", "robots:=2", *args])
    ns = "/robot_0/patrol_agent/"
    given = {k[len(ns):]: v for k, v in params.items() if k.startswith(ns)}
    assert given["robot"] == (args[0].split(":=")[1] if args else "auto")
    p = AgentParams(**{k: v for k, v in given.items()
                       if k in AgentParams.__dataclass_fields__})
    monkeypatch.delenv(ENV_VAR, raising=False)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    robot = agent_robot(p, GRID)
    assert (robot.preset, robot.speed_mps) == (preset, speed)
