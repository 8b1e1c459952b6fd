"""ROS-free logic of the tpuaf_stage simulator: world files, presets, resolved world files.

The roscpp node (src/tpuaf_stage/src/stage_node.cpp) reads resolved world files
(tpuaf_stage.resolve); the Python physics runtime builds its world from tpuaf_stage.config.
"""

from .config import LaserModel, RobotModel, WorldConfig, WorldError, load_world, parse_world

__all__ = [
    "LaserModel",
    "RobotModel",
    "WorldConfig",
    "WorldError",
    "load_world",
    "parse_world",
]
