"""CPU of the patrol_agent processes on the wall clock, by localisation source: the simulator in
rehearsal mode (`~wall_clock`, 10 Hz poses, LDS-01 at 5 Hz) with N Burgers on grid, one
`roslaunch tpuaf_ros robot.launch` per robot (own roscore on a free port), CPU of the agent
processes from /proc over a window of wall time. Writes benchmarks/results/agent_ros.md.

    .venv/bin/python benchmarks/bench_agent_ros.py [--robots 4] [--seconds 40]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from tests.ros.conftest import ros_master  # noqa: E402 - the tests' private-master helper


def children(pid: int) -> list[int]:
    """The patrol_agent processes started by process `pid` (roslaunch)."""
    out = []
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            kids = [int(x) for x in Path(f"/proc/{pid}/task/{task}/children").read_text().split()]
            out += [k for k in kids
                    if b"patrol_agent" in Path(f"/proc/{k}/cmdline").read_bytes()]
        except OSError:
            pass
    return out


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def measure(localization: str, robots: int, seconds: float) -> float:
    """Mean CPU [% of one core] per agent."""
    with tempfile.TemporaryDirectory() as tmp, ros_master(Path(tmp)) as ros:
        world = {"patrol_map": "grid", "seed": 0, "robot": {"preset": "burger"},
                 "laser": {"preset": "lds01"}, "robots": robots}
        (ros.home / "world.yaml").write_text(yaml.safe_dump(world))
        ros.start(["rosrun", "tpuaf_stage", "tpuaf_stage", f"_world:={ros.home / 'world.yaml'}",
                   "_wall_clock:=true", "_robot_prefix:=tb3_", "_scan_topic:=scan"], name="stage")
        launches = [ros.start(["roslaunch", "tpuaf_ros", "robot.launch", "map:=grid",
                               f"robots:={robots}", f"index:={i}", "prefix:=tb3_",
                               "scan_topic:=scan", "max_linear_speed:=0.22",
                               f"localization:={localization}"], name=f"tb3_{i}")
                    for i in range(robots)]
        deadline = time.monotonic() + 60.0
        agents = []
        while time.monotonic() < deadline and len(agents) < robots:
            time.sleep(1.0)
            agents = [c for launch in launches for c in children(launch.pid)]
        if len(agents) < robots:
            raise SystemExit(f"only {len(agents)} of {robots} agents started")
        time.sleep(8.0)  # start-up: run start announced, connections made
        c0 = sum(cpu_s(p) for p in agents)
        time.sleep(seconds)
        c1 = sum(cpu_s(p) for p in agents)
    return 100.0 * (c1 - c0) / seconds / len(agents)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=4)
    ap.add_argument("--seconds", type=float, default=40.0)
    args = ap.parse_args()
    rows = [(loc, measure(loc, args.robots, args.seconds)) for loc in ("tf", "ground_truth")]
    load = os.getloadavg()[0]
    text = ["# patrol_agent CPU on the wall clock, by localisation source", "",
            f"{args.robots} Burgers on grid, simulator rehearsal mode (10 Hz poses, LDS-01 5 Hz), "
            f"{args.seconds:g} s of wall time per source; machine load {load:.1f} (2 cores).",
            "`.venv/bin/python benchmarks/bench_agent_ros.py`", "",
            "| localisation | CPU per agent [% of a core] |", "|---|---|"]
    text += [f"| {loc} | {pct:.1f} |" for loc, pct in rows]
    out = REPO / "benchmarks" / "results" / "agent_ros.md"
    out.write_text("\n".join(text) + "\n")
    print("\n".join(text))


if __name__ == "__main__":
    main()
