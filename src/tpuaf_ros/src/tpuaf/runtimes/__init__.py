"""The runtimes that drive robots (docs/RUNTIMES.md). Every robot runs one state machine, the
core's `tpuaf_core.RobotProtocol` (in C++ in the graph loop, through `robot.RobotMachine`
elsewhere); a runtime supplies its clock, transport and motion:

- `graph` (event-driven, robots on graph edges; the default of `tpuaf run`; its event loop is
  the core's `GraphEngine`, C++),
- `physics` (the C++ world: laser, differential drive, collisions, with the agents' navigator),
- `agent` (one robot on a live clock: what the ROS agent node drives; the physics runtime runs
  one per robot),

plus the team `bus` (delay and loss) and `faults` (deaths, stalls) they share."""
