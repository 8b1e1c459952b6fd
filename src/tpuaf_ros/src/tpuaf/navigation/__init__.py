"""Navigation, ROS-free and shared by the physics runtime, the agent node and hardware.

- `route`: the graph route (vertex waypoints) to a goal;
- `scan`: laser scans and the one scan-to-points step;
- `controller`: the reactive local controller and its configuration;
- `navigator`: route + controller; `goal_navigator`: route + an external planner (move_base);
- `frames`: a light tf chain (map -> odom -> base).
"""

from tpuaf.navigation.controller import (
    APPROACH_MPS,
    SNUG_MARGIN_M,
    STOP_FAILED,
    Command,
    ControllerConfig,
    LocalController,
    Status,
    navigator_give_up_s,
    retry_wait_for,
    wrap_angle,
    wrap_angle_array,
)
from tpuaf.navigation.goal_navigator import GoalClient, GoalNavigator
from tpuaf.navigation.navigator import Event, Navigator
from tpuaf.navigation.route import GraphRoute
from tpuaf.navigation.scan import (
    DEFAULT_SCAN_BEAMS,
    LaserMount,
    Scan,
    beam_step,
    moved_points,
    scan_points,
    scan_points_batch,
)

__all__ = [
    "APPROACH_MPS", "SNUG_MARGIN_M", "STOP_FAILED", "Command", "ControllerConfig", "Event",
    "GoalClient", "GoalNavigator", "GraphRoute", "LocalController", "Navigator", "Scan",
    "Status", "navigator_give_up_s", "retry_wait_for", "scan_points",
    "DEFAULT_SCAN_BEAMS", "LaserMount", "beam_step", "moved_points", "scan_points_batch", "wrap_angle", "wrap_angle_array",
]
