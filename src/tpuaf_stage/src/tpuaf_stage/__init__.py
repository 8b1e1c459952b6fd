"""ROS-free logic of the tpuaf_stage simulator node: world files, presets, the stepping loop.

The node (src/tpuaf_stage/nodes/tpuaf_stage) only adapts these to ROS topics, tf and /clock.
"""

from .config import LaserModel, RobotModel, WorldConfig, WorldError, load_world, parse_world
from .loop import NodeParams, ParamError, SimLoop, parse_node_params

__all__ = [
    "LaserModel",
    "NodeParams",
    "ParamError",
    "RobotModel",
    "SimLoop",
    "WorldConfig",
    "WorldError",
    "load_world",
    "parse_node_params",
    "parse_world",
]
