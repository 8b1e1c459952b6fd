"""The rospy side of `tpuaf fleet` (the only module of tpuaf.cli that imports rospy, inside
`follow`): a progress bar in simulated time from the monitor's /fleet/metrics, and the agents
killed at their --fail times (by PID: tpuaf.cli.fleet_supervisor.kill_node)."""

from __future__ import annotations

import os
import sys
import time

from tpuaf.cli.fleet_supervisor import kill_node
from tpuaf.topics import METRICS_TOPIC


def follow(args, env, launch, deaths, deaths_done, prefix: str) -> tuple[bool, float, float]:
    """Follow /fleet/metrics with a progress bar until finished, roslaunch died or timeout;
    kill agents (/<prefix><robot>/patrol_agent) at their --fail times. Returns (finished,
    elapsed run s, wall s of the run)."""
    os.environ.update({k: env[k] for k in ("ROS_MASTER_URI", "ROS_IP", "ROS_HOME", "ROS_LOG_DIR")})
    import rospy
    from tqdm import tqdm

    from tpuaf_ros.msg import LiveMetrics

    state = {"elapsed": 0.0, "finished": False, "t_first": None, "t_last": None}

    def on_metrics(msg):
        now = time.monotonic()
        if state["t_first"] is None:
            state["t_first"] = now
            state["e_first"] = msg.elapsed
        state["elapsed"] = msg.elapsed
        state["t_last"] = now
        if msg.finished:
            state["finished"] = True

    rospy.init_node("tpuaf_fleet_cli", anonymous=True, disable_signals=True)
    rospy.Subscriber(METRICS_TOPIC, LiveMetrics, on_metrics, queue_size=10)
    bar = tqdm(total=args.duration, unit="sim s", disable=args.quiet, desc=args.strategy,
               bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} sim s [{elapsed}<{remaining}]",
               file=sys.stderr)
    timeout = args.timeout if args.timeout else args.duration + 300.0
    pending = list(deaths)
    t0 = time.monotonic()
    try:
        while not state["finished"]:
            if launch.poll() is not None:
                break
            if time.monotonic() - t0 > timeout:
                print(f"tpuaf fleet: wall-clock limit of {timeout:g} s reached", file=sys.stderr)
                break
            while pending and state["t_first"] is not None and state["elapsed"] >= pending[0]["time_s"]:
                fault = pending.pop(0)
                node = f"/{prefix}{fault['robot']}/patrol_agent"
                pid = kill_node(env["ROS_MASTER_URI"], node)
                deaths_done.append({**fault, "killed_at_s": state["elapsed"], "pid": pid})
                bar.write(f"tpuaf fleet: killed {node} (pid {pid}) at run time "
                          f"{state['elapsed']:.1f} s")
            bar.update(state["elapsed"] - bar.n)
            time.sleep(0.1)
        bar.update(state["elapsed"] - bar.n)
    finally:
        bar.close()
        if state["finished"]:
            time.sleep(1.0)  # let rosbag write the last messages
        rospy.signal_shutdown("tpuaf fleet done")
    return state["finished"], state["elapsed"], _wall_run(state, args.duration)


def _wall_run(state: dict, duration_s: float) -> float:
    """[s of wall time] the whole run would take at the pace seen from the first to the last
    metrics message (metrics start at elapsed ~0); 0 without two distinct messages."""
    if state["t_first"] is None:
        return 0.0
    span = state["elapsed"] - state["e_first"]
    wall = state["t_last"] - state["t_first"]
    return wall * duration_s / span if span > 0 else 0.0
