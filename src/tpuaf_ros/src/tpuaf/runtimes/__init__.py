"""The runtimes that drive robots: `graph` (event-driven, no physics, no ROS; the default of
`tpuaf run`), `agent` (one robot on a live clock, driven by the ROS agent node) and the team
`bus` (delay and loss) they share."""
