"""ROS 1 adapters of tpuaf: message conversion, the agent runtime and the monitor logic.

Nothing in this package imports rospy: the node scripts (src/tpuaf_ros/nodes/) own the ROS I/O
and hand times [s], poses and converted messages to these classes, so that they are testable
without a ROS master. `convert` needs the generated `tpuaf_ros.msg` classes (genpy only).
"""
