"""tpuaf: multi-robot continuous monitoring with the TPUAF strategy and classic baselines.

The logic here knows nothing of ROS; the ROS nodes in tpuaf_ros/nodes and tpuaf_stage only adapt.
"""

__version__ = "0.1.0"
