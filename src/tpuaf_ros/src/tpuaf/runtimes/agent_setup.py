"""What the patrol_agent node builds from its parameters (ROS-free): the checks across
parameters, the robot model, the local controller's configuration, the AgentRuntime with its
plan map and lane layer, and the odometry origin."""

from __future__ import annotations

import math
from dataclasses import replace

from tpuaf.maps import start_vertices
from tpuaf.navigation import ControllerConfig, retry_wait_for
from tpuaf.params import (
    LANE_MODES,
    AgentParams,
    NodeParamError,
    resolve_lane_mode,
)
from tpuaf.robot.lanes import LaneLayer, attach_lanes, lane_layer
from tpuaf.robot.model import RobotChoiceError, RobotModel, choose_robot
from tpuaf.runtimes.agent import AgentRuntime

LOCALIZATIONS = ("tf", "odom", "ground_truth", "amcl")
NAVIGATIONS = ("builtin", "move_base")


def agent_robot(p: AgentParams, patrol_map) -> RobotModel:
    """The robot model of ~robot (auto: TURTLEBOT3_MODEL, else the map's preset) with the
    ~max_linear_speed, ~max_angular_speed and ~robot_radius overrides (0: the robot's)."""
    try:
        robot = choose_robot(p.robot, patrol_map.settings, option="~robot")
    except RobotChoiceError as err:
        raise NodeParamError(str(err)) from None
    return replace(robot, speed_mps=p.max_linear_speed or robot.speed_mps,
                   max_angular_speed=p.max_angular_speed or robot.max_angular_speed,
                   radius_m=p.robot_radius or robot.radius_m)


def check_agent_params(p: AgentParams, sim: bool) -> None:
    """Cross-parameter and choice checks (one-line NodeParamError naming the problem); the
    numeric limits of single parameters are AgentParams.ranges, checked by `parse`."""
    if not 0 <= p.robot_index < p.robots:
        raise NodeParamError(f"~robot_index {p.robot_index} not in 0..{p.robots - 1}")
    if p.localization not in LOCALIZATIONS:
        raise NodeParamError(f"~localization must be one of {', '.join(LOCALIZATIONS)}, got "
                             f"{p.localization!r}")
    if p.navigation not in NAVIGATIONS:
        raise NodeParamError(f"~navigation must be builtin or move_base, got {p.navigation!r}")
    if p.initial_pose and (len(p.initial_pose) != 3 or not all(
            isinstance(v, (int, float)) and math.isfinite(v) for v in p.initial_pose)):
        raise NodeParamError(f"~initial_pose must be [x, y, yaw], got {p.initial_pose}")
    if sim and p.clock_offset != 0.0:
        raise NodeParamError("~clock_offset needs the wall clock (use_sim_time false)")
    if p.lockstep and p.navigation == "move_base":
        raise NodeParamError("~lockstep needs ~navigation builtin (move_base drives the robot)")
    if p.lanes not in LANE_MODES:
        raise NodeParamError(f"~lanes must be one of {', '.join(LANE_MODES)}, got {p.lanes!r}")
    if p.lanes not in ("auto", "off") and not finds_lanes(p):
        raise NodeParamError(f"~lanes {p.lanes} needs ~navigation builtin with ~global_planner "
                             "true (lanes are found on the planned paths)")


def finds_lanes(p: AgentParams) -> bool:
    """Whether this agent's navigation can find lanes (on the planned paths)."""
    return p.navigation == "builtin" and p.global_planner


def agent_lane_mode(p: AgentParams) -> str:
    """The lane mode this agent runs (auto: params.resolve_lane_mode, off without the planned
    paths lanes are found on)."""
    if p.lanes == "auto" and not finds_lanes(p):
        return "off"
    return resolve_lane_mode(p.lanes, p.strategy)


def agent_runtime(p: AgentParams, patrol_map, robot: RobotModel, policy, publish_team,
                  publish_event) -> tuple[AgentRuntime, object, LaneLayer | None]:
    """(runtime, plan map, lane layer or None) of this robot, as the physics runtime builds
    them: built-in navigation plans on the map's occupancy grid; the strategy plans on the
    robot's speed and travel times, along the one-way lanes (~lanes one_way); the lane layer
    holds the start's lane when the runtime begins."""
    from tpuaf.navigation.planner import shared_planner
    from tpuaf.navigation.travel_time import timed_map

    cfg = agent_controller(p, robot)
    planner = (shared_planner(patrol_map, cfg.robot_radius)
               if p.navigation == "builtin" and p.global_planner else None)
    plan_map = timed_map(patrol_map, robot, shared_planner(patrol_map, robot.radius_m))
    mode = agent_lane_mode(p)
    layer = (lane_layer(planner, patrol_map, plan_map, mode == "one_way", without_lanes=True)
             if mode != "off" else None)
    if layer is not None:
        plan_map = layer.plan_map
    runtime = AgentRuntime(plan_map, policy, p.robot_index, p.robots, p.seed, publish_team,
                           publish_event, cfg, p.heartbeat_period, p.waypoint_tolerance,
                           planner, teammate_timeout_s=p.teammate_timeout)
    if layer is not None:
        attach_lanes(runtime, layer, None)
    return runtime, plan_map, layer


def agent_controller(p: AgentParams, robot: RobotModel) -> ControllerConfig:
    """The local controller of this robot: its model's limits and the node's margins and
    recovery parameters."""
    return ControllerConfig(
        max_linear_speed=robot.speed_mps,
        max_angular_speed=robot.max_angular_speed,
        robot_radius=robot.radius_m,
        safety_margin=p.safety_margin, plan_margin=p.plan_margin,
        stuck_timeout_s=p.stuck_timeout, backoff_s=p.backoff_time, max_retries=p.max_retries,
        retry_wait_s=retry_wait_for(p.robot_index),
    )


def odom_origin(p: AgentParams, patrol_map) -> tuple[float, float, float] | None:
    """The pose [m, m, rad] of the odom frame in the map frame with ~localization odom:
    ~initial_pose, else the robot's start vertex (heading 0); None with another localisation."""
    if p.localization != "odom":
        return None
    if p.initial_pose:
        return tuple(float(v) for v in p.initial_pose)
    v = start_vertices(patrol_map, p.robots)[p.robot_index]
    return (*map(float, patrol_map.positions[v]), 0.0)
