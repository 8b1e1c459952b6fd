"""Physics runtime: the team in the C++ world (laser, differential drive, collisions) without ROS.

The reference the ROS fleet is measured against (`tpuaf run --runtime physics`). Per robot it
runs exactly what the ROS agent node runs, `AgentRuntime` (the shared `RobotMachine` with the
`Navigator`: graph route + reactive local controller on the laser), on the world the fleet's
simulator steps (`tpuaf_core.World`, built from the same world description as `tpuaf fleet`:
the map's occupancy image or generated corridors, a robot preset, the LDS-01 laser). Team
messages go through `TeamBus` (delay, loss) as in the graph runtime; ground truth goes to the
same `RunRecorder`; visits are the agents' REACHED events.

Clock: a fixed control period (default 0.1 s, the fleet's 10 Hz odometry), each one
`control_period_s / physics_step_s` world steps (default 0.05 s); scans at the laser's rate
(LDS-01: 5 Hz, every other control tick, as in the fleet). At each control tick k (t = k T):
faults due, messages due, ground-truth positions to the recorder, then every live robot in
index order gets its pose and its latest scan and answers a command (messages sent on the way
are delivered before the next robot's turn when the bus has no delay), then the world steps.
Deterministic per seed: world noise [seed], bus [seed, 1], policies [seed, 2, i].

Liveness (runs with faults): as the fleet's agents, every robot hears its teammates' heartbeats
(one per `heartbeat_period_s`, with the bus's loss and delay: `heartbeat_links`) and team
messages, and takes a teammate silent for `teammate_timeout_s` for lost (`TeamRun`); checks
fall on the control ticks. A stalled robot keeps its heartbeats.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import asdict

import numpy as np

from tpuaf.maps import start_poses, start_vertices
from tpuaf.navigation import (
    ControllerConfig,
    LaserMount,
    retry_wait_for,
    scan_points_batch,
)
from tpuaf.navigation.planner import shared_planner
from tpuaf.params import LIVENESS_DEFAULTS
from tpuaf.policies import REGISTRY
from tpuaf.robot.lanes import attach_lanes, lane_layer
from tpuaf.robot.model import RobotModel, world_robot
from tpuaf.runtimes.agent import AgentRuntime
from tpuaf.runtimes.base import TeamRun
from tpuaf.runtimes.config import PhysicsConfig, RunConfig, run_description


def controller_config(index: int, robot: RobotModel) -> ControllerConfig:
    """The local controller of robot `index`, as the agent node configures it by default."""
    return ControllerConfig(max_linear_speed=robot.speed_mps,
                            max_angular_speed=robot.max_angular_speed,
                            robot_radius=robot.radius_m, retry_wait_s=retry_wait_for(index))


class PhysicsRun(TeamRun):
    """One physics-runtime run; the interface of GraphRun (config, patrol_map, now, recorder,
    run(progress), summary(), effective_config())."""

    runtime = "physics"

    def __init__(self, config: PhysicsConfig | RunConfig, patrol_map=None):
        from tpuaf_stage.config import WorldConfig, parse_laser, parse_robot

        if not isinstance(config, PhysicsConfig):
            config = PhysicsConfig(**asdict(config))
        super().__init__(config, patrol_map)
        pm = self.patrol_map  # the plan's (routes, strategies, metrics)
        world_map = self.source_map  # the geometry (world, planner)
        n = config.robots
        preset, robot_model = parse_robot(None, world_robot(self.robot))
        laser_preset, laser = parse_laser(None, {"preset": "lds01"})
        self.starts = starts = start_vertices(pm, n)
        grid = world_map.occupancy_grid()
        self.world_config = WorldConfig(
            source=None, occupied=np.asarray(grid.occupied, dtype=bool),
            resolution=float(grid.resolution), origin=(float(grid.origin[0]),
                                                       float(grid.origin[1])),
            robot=robot_model, laser=laser,
            poses=start_poses(pm, n, robot_model.radius, starts),
            seed=self.seed, map_description=f"patrol map {world_map.name}", robot_preset=preset,
            laser_preset=laser_preset)
        self.world = self.world_config.build()
        self.body_radius_m = float(robot_model.radius)  # a dead robot stays in the world
        self._record()
        cls = REGISTRY.get(config.strategy)
        # One planner (costmap and edge paths) for the team: they share the footprint.
        self.planner = (shared_planner(world_map, robot_model.radius) if config.planner
                        else None)
        self.recorder.planner = self.planner  # the bodies' truth: the robots' own planner
        # The lane layer where the map has stretches one robot wide (docs/LANES.md); with
        # one-way lanes the plan's graph (routes, strategies' travel times) follows the arcs.
        layer = (lane_layer(self.planner, world_map, pm, config.one_way, without_lanes=True)
                 if self.planner is not None and config.lane_mode() != "off" else None)
        self.lane_map = layer.lane_map if layer is not None else None
        self.orientation = layer.orientation if layer is not None else None
        if layer is not None:
            self.patrol_map = pm = layer.plan_map
        self.agents = [
            AgentRuntime(pm, cls(config.strategy_params), i, n, self.seed,
                         self._publisher(i), self.visit_listener(i),
                         controller_config(i, self.robot),
                         planner=self.planner, teammate_timeout_s=config.teammate_timeout_s)
            for i in range(n)
        ]
        self.heartbeat_period_s = (self.agents[0].heartbeat_period_s if n
                                   else LIVENESS_DEFAULTS.heartbeat_period_s)
        self._liveness_checks: list[tuple[float, int, int]] = []  # heap: (t [s], robot, token)
        self._team([a.machine for a in self.agents])
        self.lane_access = ([attach_lanes(a, layer, starts[i])
                             for i, a in enumerate(self.agents)] if layer is not None else [])
        self.steps_per_control = round(config.control_period_s / config.physics_step_s)
        # Scans at the laser rate, on control ticks (LDS-01 5 Hz: every other 10 Hz tick).
        self.scan_every = max(1, round(1.0 / (laser.rate * config.control_period_s)))
        self.collisions = 0

    def _publisher(self, robot: int) -> Callable:
        def publish(message) -> None:
            self.bus.send(robot, message, self.now)

        return publish

    def _liveness_at(self, time_s: float, robot: int, token: int) -> None:
        heapq.heappush(self._liveness_checks, (time_s, robot, token))

    def _points(self, ranges: np.ndarray) -> list[np.ndarray]:
        """Laser points (k, 2) in the base frame per robot: the agent node's scan step
        (navigation.scan_points_batch), keeping only what the controller can use."""
        lz = self.world_config.laser
        return scan_points_batch(ranges, lz.first_angle, lz.angle_increment, lz.range_min,
                                 lz.range_max, LaserMount(lz.x, lz.y, lz.yaw),
                                 within_m=self.agents[0].navigator.controller.reach_m)

    # --- main loop ---
    def run(self, progress: Callable[[float], None] | None = None) -> dict:
        """Simulate until duration_s. `progress(now)` is called now and then."""
        cfg = self.config
        end = float(cfg.duration_s)
        period = float(cfg.control_period_s)
        step = float(cfg.physics_step_s)
        agents = self.agents
        world = self.world
        n = len(agents)
        faults = list(self.faults)
        commands = np.zeros((n, 2))
        points: list = [None] * n
        scan_rows: list = [None] * n
        stopped = np.zeros(n, dtype=bool)  # dead or stalled: the world gets zero commands
        poses = np.asarray(world.poses(), dtype=float)
        self.recorder.record_positions(0.0, poses[:, :2])
        for i, a in enumerate(agents):
            a.on_pose(0.0, *poses[i])
        for a in agents:
            a.begin(0.0)
            self.deliver_ready()
        self.start_liveness()
        checks = self._liveness_checks
        n_ticks = int(math.floor(end / period + 1e-9))
        next_progress = 0.0
        for k in range(n_ticks + 1):
            t = k * period
            self.now = t
            while faults and faults[0].time_s <= t + 1e-9:
                fault = faults.pop(0)
                self.inject(fault)
                stopped[fault.robot] = True
            self.bus.release_due(t)
            self.deliver_ready()
            while checks and checks[0][0] <= t + 1e-9:  # after the messages due by now
                _, robot, token = heapq.heappop(checks)
                self.liveness_due(robot, token)
                self.deliver_ready()
            if k:
                poses = np.asarray(world.poses(), dtype=float)
                self.recorder.record_positions(t, poses[:, :2])
            if k % self.scan_every == 0:
                points = self._points(np.asarray(world.scan_all(), dtype=float))
                scan_rows = poses.tolist()  # the poses the points were measured at
            if k == n_ticks:
                break
            rows = poses.tolist()
            for i, a in enumerate(agents):
                if not a.machine.alive:
                    commands[i] = 0.0
                    continue
                x, y, th = rows[i]
                a.on_pose(t, x, y, th)
                commands[i] = a.tick(t, points[i], scan_rows[i])
                if self.bus.has_ready:
                    self.deliver_ready()
            if stopped.any():
                commands[stopped] = 0.0
            world.set_commands(commands)
            for _ in range(self.steps_per_control):
                world.step(step)
            if progress is not None and t >= next_progress:
                progress(t)
                next_progress = t + end / 200.0
        if n_ticks * period < end:
            self.now = end
            poses = np.asarray(world.poses(), dtype=float)
            self.recorder.record_positions(end, poses[:, :2])
        self.now = end
        self.collisions = int(sum(world.contact_counts()))
        if progress is not None:
            progress(end)
        return self.summary()

    def effective_config(self) -> dict:
        """Everything that determines this run, with defaults resolved (written to config.yaml)."""
        return run_description(
            self, self.starts, self.agents[0].policy.params, self.faults,
            world=self.world_config.summary(), robot_model=self.robot.describe(),
            controller=asdict(self.agents[0].navigator.controller.config),
            planner=(asdict(self.planner.config) if self.planner is not None else None),
            motion=(f"C++ world, {self.config.physics_step_s:g} s steps; agents' navigator "
                    f"at {1 / self.config.control_period_s:g} Hz on ground-truth poses, "
                    + ("along planned paths" if self.planner is not None
                       else "along straight edges")))

    def summary(self) -> dict:
        summary = super().summary()
        summary["replans"] = int(sum(a.navigator.replans for a in self.agents))
        summary["recoveries"] = int(sum(a.recoveries for a in self.agents))
        summary["collisions"] = int(sum(self.world.contact_counts()))
        summary["goal_failures"] = int(sum(a.machine.failures for a in self.agents))
        # goals ended short of the vertex, held there by another robot (DWELL, no visit)
        summary["short_arrivals"] = int(sum(a.navigator.short_arrivals for a in self.agents))
        if self.lane_access:  # lane waits: requests not granted at once, and their time [s]
            locks = [access.locks for access in self.lane_access]
            summary["lanes"] = len(self.lane_map.lanes)
            if self.orientation is not None:
                summary["one_way_lanes"] = len(self.orientation.chains)
            summary["lane_waits"] = int(sum(lk.waits for lk in locks))
            summary["lane_wait_s"] = round(float(sum(lk.wait_s for lk in locks)), 3)
            # edges dropped from the plan: a lost teammate's body on them (robot/lanes.py),
            # by vertex id; the vertices it cuts off come as the agents' VERTEX_CLOSED events
            # (the recorder's `lane_vertices_closed`, as in the fleet monitor)
            ids = self.patrol_map.vertex_ids
            summary["lane_edges_blocked"] = [
                [ids[u], ids[v]] for u, v in sorted({e for access in self.lane_access
                                                     for e in access.blocked})]
        return summary
