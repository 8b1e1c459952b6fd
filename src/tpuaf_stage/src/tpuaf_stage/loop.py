"""The stepping loop of the simulator, without ROS: node parameters, watchdog, publication
schedule and real-time pacing. The tpuaf_stage node feeds it commands and publishes what a tick
says is due.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from tpuaf.params import NodeParamError, parse

from .config import WorldConfig

# A node parameter is unknown or has a bad value (the strict parser shared by all nodes).
ParamError = NodeParamError


@dataclass
class NodeParams:
    """Private parameters of the tpuaf_stage node (`~name`). Unit and default in the comments."""

    world: str = ""  # path of the world YAML file (required)
    step: float = 0.01  # [s] fixed physics step of simulated time
    clock_rate: float = 100.0  # [Hz of sim time] /clock messages; at most 1 / step
    real_time_factor: float = 0.0  # [-] simulated s per wall s; 0 = as fast as possible
    odom_rate: float = 10.0  # [Hz of sim time] odom, base_pose_ground_truth and /tf
    robot_prefix: str = "robot_"  # robot i lives in namespace <robot_prefix><i>
    cmd_vel_timeout: float = 0.2  # [s of sim time] a robot with an older cmd_vel gets zero
    map_frame: str = "map"  # global frame of the ground truth and of map -> <ns>/odom
    publish_map_tf: bool = True  # also publish map -> <ns>/odom (perfect localisation)
    scan_topic: str = "base_scan"  # per-robot laser topic name (TurtleBot3 uses "scan")
    status_period: float = 10.0  # [s of wall time] between status log lines; 0 = none
    lockstep: bool = False  # after each scan, wait for one cmd_vel per robot before going on
    lockstep_timeout: float = 1.0  # [s of wall time] wait per scan for a robot's reply; a robot
    #   that misses it is not waited for again until it replies
    start_timeout: float = 60.0  # [s of wall time] lockstep: wait at start until every robot's
    #   cmd_vel has a publisher (then go on without the missing ones)
    wall_clock: bool = False  # hardware rehearsal: real-time pace, wall-clock stamps, no /clock


PARAM_DOCS = {
    "world": "path of the world YAML file (required)",
    "step": "[s] fixed physics step (default 0.01)",
    "clock_rate": "[Hz, sim time] /clock messages, at most 1/step (default 100)",
    "real_time_factor": "[-] simulated seconds per wall second, 0 = as fast as possible (default 0)",
    "odom_rate": "[Hz, sim time] rate of odom, base_pose_ground_truth and /tf (default 10)",
    "robot_prefix": "robot i lives in namespace <robot_prefix><i> (default robot_)",
    "cmd_vel_timeout": "[s, sim time] cmd_vel older than this stops the robot (default 0.2)",
    "map_frame": "global frame (default map)",
    "publish_map_tf": "publish map -> <ns>/odom too (default true)",
    "scan_topic": "per-robot laser topic (default base_scan)",
    "status_period": "[s, wall time] between status log lines, 0 = none (default 10)",
    "lockstep": "wait for one cmd_vel per robot after each scan (default false)",
    "lockstep_timeout": "[s, wall time] lockstep wait per scan for a robot's reply (default 1)",
    "start_timeout": "[s, wall time] lockstep: wait at start for every cmd_vel publisher "
                     "(default 60)",
    "wall_clock": "hardware rehearsal: real-time pace, wall-clock stamps, no /clock "
                  "(default false; agents run with use_sim_time false)",
}


def parse_node_params(values: dict[str, Any]) -> NodeParams:
    """NodeParams from {name: value} (private names without '~'); unknown names are refused."""
    p = parse(NodeParams, values, "tpuaf_stage")
    if p.wall_clock:
        p.real_time_factor = 1.0
    if not p.world:
        raise ParamError("~world (path of the world YAML file) is required")
    if not p.step > 0:
        raise ParamError(f"~step must be > 0 s, got {p.step}")
    if p.real_time_factor < 0:
        raise ParamError(f"~real_time_factor must be >= 0 (0 = as fast as possible), got "
                         f"{p.real_time_factor}")
    if not 0 < p.clock_rate <= 1.0 / p.step + 1e-9:
        raise ParamError(f"~clock_rate must be > 0 and <= 1/step = {1.0 / p.step:g} Hz, got "
                         f"{p.clock_rate}")
    if not p.odom_rate > 0:
        raise ParamError(f"~odom_rate must be > 0 Hz, got {p.odom_rate}")
    if not p.cmd_vel_timeout > 0:
        raise ParamError(f"~cmd_vel_timeout must be > 0 s, got {p.cmd_vel_timeout}")
    if not p.lockstep_timeout > 0 or not p.start_timeout >= 0:
        raise ParamError("~lockstep_timeout must be > 0 s and ~start_timeout >= 0 s")
    if p.status_period < 0:
        raise ParamError(f"~status_period must be >= 0 s, got {p.status_period}")
    for name in ("robot_prefix", "map_frame", "scan_topic"):
        value = getattr(p, name)
        if not value or value.startswith("/") or " " in value:
            raise ParamError(f"~{name} must be a non-empty relative name, got {value!r}")
    return p


def params_summary(p: NodeParams) -> dict:
    return asdict(p)


class _Schedule:
    """Publication at `rate_hz` of simulated time on a fixed step: due at the first step whose
    time reaches k / rate (exact, by step count)."""

    def __init__(self, rate_hz: float, step_s: float):
        self.rate = rate_hz
        self.step = step_s
        self.count = 0

    def due(self, n_steps: int) -> bool:
        k = math.floor(n_steps * self.step * self.rate + 1e-9)
        if k > self.count:
            self.count = k
            return True
        return False


@dataclass
class Tick:
    time: float  # [s] simulated time after the step
    time_ns: int  # the same in integer nanoseconds (exact, for stamps)
    clock: bool  # publish /clock now
    odom: bool  # publish odom, ground truth and tf now
    scan: bool  # publish the scans now


class SimLoop:
    """World + fixed step + watchdog + publication schedule. Commands may come from other
    threads (ROS callbacks): each is a pair of array element writes."""

    def __init__(self, config: WorldConfig, params: NodeParams):
        self.config = config
        self.params = params
        self.world = config.build()
        n = self.world.num_robots
        self.n = n
        self.step_ns = round(params.step * 1e9)
        if self.step_ns <= 0:
            raise ParamError(f"~step {params.step} s is below a nanosecond")
        self.steps = 0
        self.commands = np.zeros((n, 2))
        self.last_command = np.full(n, -math.inf)  # [s of sim time]
        self.stopped_by_watchdog = np.zeros(n, dtype=bool)
        # Lock-step: replies (cmd_vel) counted per robot; robots that missed a reply in time.
        self.replies = np.zeros(n, dtype=np.int64)
        self.unresponsive = np.zeros(n, dtype=bool)
        self._replied = threading.Condition()
        self._clock = _Schedule(params.clock_rate, params.step)
        self._odom = _Schedule(params.odom_rate, params.step)
        self._scan = _Schedule(config.laser.rate, params.step)

    @property
    def time(self) -> float:
        return self.steps * self.step_ns * 1e-9

    @property
    def time_ns(self) -> int:
        return self.steps * self.step_ns

    def command(self, i: int, v: float, w: float) -> None:
        """cmd_vel of robot i (v [m/s], w [rad/s]), received now (sim time)."""
        self.commands[i, 0] = v
        self.commands[i, 1] = w
        self.last_command[i] = self.time
        if self.params.lockstep:
            with self._replied:
                self.replies[i] += 1
                self.unresponsive[i] = False
                self._replied.notify_all()

    def reply_marks(self) -> np.ndarray:
        """Reply counters now (before publishing a scan), for wait_replies."""
        with self._replied:
            return self.replies.copy()

    def wait_replies(self, marks: np.ndarray, timeout_s: float, stop=lambda: False) -> list[int]:
        """Lock-step: wait (wall time) until every responsive robot has replied since `marks`.
        Robots still silent after timeout_s become unresponsive (not waited for until they
        reply again); returns them."""
        deadline = time.monotonic() + timeout_s
        with self._replied:
            while True:
                waiting = (self.replies <= marks) & ~self.unresponsive
                if not waiting.any():
                    return []
                left = deadline - time.monotonic()
                if left <= 0 or stop():
                    late = np.flatnonzero(waiting).tolist()
                    self.unresponsive[late] = True
                    return late
                self._replied.wait(min(left, 0.5))

    def advance(self) -> Tick:
        """One fixed step: watchdog, world step, what to publish."""
        stale = (self.time - self.last_command) > self.params.cmd_vel_timeout + 1e-9
        self.stopped_by_watchdog = stale
        cmd = self.commands.copy()
        cmd[stale] = 0.0
        self.world.set_commands(cmd)
        self.world.step(self.params.step)
        self.steps += 1
        n = self.steps
        return Tick(self.time, self.time_ns, self._clock.due(n), self._odom.due(n), self._scan.due(n))

    def reset(self) -> None:
        """Robots back to their initial poses, at rest, commands forgotten (time goes on)."""
        self.world.reset()
        self.commands[:] = 0.0
        self.last_command[:] = -math.inf
        self.stopped_by_watchdog[:] = True

    def wall_delay(self, wall_elapsed_s: float, sim_start_s: float = 0.0) -> float:
        """[s] to sleep so that simulated time keeps real_time_factor; 0 when free-running."""
        rtf = self.params.real_time_factor
        if rtf <= 0:
            return 0.0
        return (self.time - sim_start_s) / rtf - wall_elapsed_s
