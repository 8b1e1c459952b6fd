"""Measurement: the one metrics recorder, the fleet monitor, pose streams, bag analysis and
the ROS-free logic of the RViz markers."""
