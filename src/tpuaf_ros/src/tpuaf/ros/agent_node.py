"""patrol_agent: one robot's strategy and navigator on ROS 1 (thin adapter, see docs/HARDWARE.md).

In the robot's namespace: subscribes its laser `base_scan` (remap to `scan` on a TurtleBot3) and
its pose from /tf (map -> <ns>/base_footprint, any localiser; the hardware default), odom,
base_pose_ground_truth or amcl_pose; the team topics (/team/*, typed tpuaf_ros messages), the
agents' heartbeats (/fleet/agent_events) and the run start (/fleet/start, latched). Publishes
cmd_vel (Twist, one per pose tick; TwistStamped on cmd_vel_stamped in lock-step; nothing with
the move_base backend, which sends MoveBaseAction goals), team messages on events and AgentEvent
on /fleet/agent_events. Works on the wall clock (hardware) and on /clock (simulation).
Private parameters: tpuaf.params.AgentParams (strict; `patrol_agent --help`).
"""

import math
import re
import threading
import time
import warnings

import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist, TwistStamped
from nav_msgs.msg import Odometry
from rospy.numpy_msg import numpy_msg
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Int64MultiArray, String
from tf2_msgs.msg import TFMessage

from tpuaf import topics
from tpuaf.maps import MapError, load_map
from tpuaf.navigation import GoalNavigator, LaserMount, Scan, scan_points
from tpuaf.navigation.frames import FrameChain, StaticFrames, compose
from tpuaf.params import AgentParams, NodeParamError, parse
from tpuaf.policies import REGISTRY, ParameterError
from tpuaf.ros import convert
from tpuaf.ros.node import (
    fatal,
    private_params,
    publish,
    run_node,
    send_initial_pose,
    sender_of,
    yaw_of,
)
from tpuaf.runtimes.agent_setup import (
    agent_robot,
    agent_runtime,
    check_agent_params,
    odom_origin,
)
from tpuaf.team.epoch import ADOPTED, INVALID, KEPT, RunEpoch
from tpuaf.team.inbox import InboxConfig, TeamInbox
from tpuaf.team.liveness import InputWatchdog
from tpuaf.team.lockstep import LockstepTeam
from tpuaf_ros.msg import AgentEvent, RunStart

NODE = "patrol_agent"
# lock-step: the order of one sender's messages of one stamp (team topics, then its events)
TOPIC_RANK = {name: k for k, name in enumerate(topics.TEAM_TOPICS)}
WARN_PERIOD_S = 5.0  # [s wall] throttle of repeated warnings
FULL_CIRCLE_RAD = 2.0 * math.pi - 0.1  # [rad] a scan this wide sees behind the robot
warnings.filterwarnings("ignore", message="The publisher should be created with an explicit")


def _shape(reason: str) -> str:
    """A reason without its numbers (the throttle key of its warning)."""
    return re.sub(r"[-+0-9.e]+", "#", reason)


class AgentNode:
    def __init__(self, p: AgentParams, patrol_map, sim: bool):
        self._identity(p, patrol_map, sim)
        self._publishers(p)
        self._runtime(p, patrol_map, sim)
        self.control_on_scan = p.localization == "amcl"
        self._t0_wall = time.monotonic()
        self._subscribers(p)
        self._thread = threading.Thread(target=self.supervise, daemon=True)
        self._thread.start()

    def _identity(self, p: AgentParams, patrol_map, sim: bool) -> None:
        """Names, the run's epoch, the team inbox and the input watchdog."""
        self.p = p
        self.sim = sim
        self.lock = threading.Lock()
        ns = rospy.get_namespace().strip("/")
        name = p.robot_name or ns or f"robot_{p.robot_index}"
        prefix = name[: -len(str(p.robot_index))] if name.endswith(str(p.robot_index)) else name + "_"
        self.name = name
        # Run time = ROS time (+ clock_offset on the wall clock) - epoch. Sim: epoch 0 and the
        # start on /fleet/start; wall clock: the epoch IS the start announced on /fleet/start.
        if p.epoch >= 0:
            self.epoch = float(p.epoch)
        else:
            self.epoch = 0.0 if sim else None
        self.conv = convert.Converter(patrol_map, prefix=prefix, epoch=self.epoch or 0.0)
        self.names = [f"{prefix}{i}" for i in range(p.robots)]
        self.inbox = TeamInbox(p.robots, patrol_map.num_vertices, p.robot_index, InboxConfig(
            skew_warn_s=p.skew_warn, max_skew_s=p.max_skew, correct_skew=not sim), self.names)
        self.team_ticks = LockstepTeam(p.robots, p.robot_index, p.max_skew) if p.lockstep else None
        self._answered_ns = 0  # lock-step: stamp [ns] of the tick answered last
        pose_input = "tf " + p.map_frame if p.localization == "tf" else p.localization
        watched = ("scan", "clock") if p.localization == "amcl" else ("pose", "scan", "clock")
        self.inputs = InputWatchdog(watched, p.input_timeout)  # amcl_pose: on change only
        self.pose_input = pose_input
        self.halted = True  # until pose, scan and clock are fresh
        self._warned = {}  # key -> wall time of the last warning

    def _publishers(self, p: AgentParams) -> None:
        """Velocity (or stamped velocity in lock-step), events, the run start, team messages."""
        self.lockstep = p.lockstep
        self.drives = p.navigation == "builtin"
        self.cmd_pub = None  # move_base drives: no velocity publisher at all
        if self.lockstep:
            self.cmd_pub = rospy.Publisher(topics.CMD_VEL_STAMPED, TwistStamped, queue_size=None,
                                           tcp_nodelay=True)
            self.cmd = TwistStamped()
            self.twist = self.cmd.twist
            self.counts_pub = rospy.Publisher(topics.LOCKSTEP_TEAM, Int64MultiArray,
                                              queue_size=None, tcp_nodelay=True)
        else:
            self.cmd = self.twist = Twist()
            if self.drives:
                self.cmd_pub = rospy.Publisher(topics.CMD_VEL, Twist, queue_size=None,
                                               tcp_nodelay=True)
        # latched: a subscriber that connects late (a monitor slow to start, while a lock-step
        # simulator holds time before the run start) still gets our last event, the "ready"
        self.event_pub = rospy.Publisher(topics.EVENTS_TOPIC, AgentEvent, queue_size=None,
                                         latch=True)
        self.rejections_pub = rospy.Publisher(topics.REJECTIONS_TOPIC, String, queue_size=1,
                                              latch=True)
        # The run start the team agreed on, re-latched by every agent that knows it.
        self.run_start = RunEpoch()
        self.start_pub = rospy.Publisher(topics.START_TOPIC, RunStart, queue_size=1, latch=True)
        self.team_pub = {}
        for cls, ros_cls in self.conv.types.items():
            self.team_pub[cls] = rospy.Publisher(topics.team_topic(p.team_ns, cls), ros_cls,
                                                 queue_size=None)
        self.event = AgentEvent()
        self.event.robot = self.name
        self.event.robot_index = p.robot_index

    def _runtime(self, p: AgentParams, patrol_map, sim: bool) -> None:
        """The robot's model, controller, strategy and AgentRuntime; navigation and the pose
        origin."""
        robot = agent_robot(p, patrol_map)
        self.robot = robot
        self.runtime, self.plan_map, lanes = agent_runtime(
            p, patrol_map, robot, REGISTRY.create(p.strategy, p.strategy_params),
            self.publish_team, self.publish_event)
        if lanes is not None:  # LaneClaim messages are checked against the team's lanes
            self.inbox.n_lanes = len(lanes.lane_map.lanes)
            rospy.loginfo(f"{self.name}: lanes {p.lanes}: {lanes.describe()}")
        self.liveness = self.runtime.machine.liveness  # the machine's (RobotMachine.hear)
        self.runtime.on_stuck = self.report_stuck
        # [m] laser points farther from the base than this cannot matter to the controller
        self.points_within_m = self.runtime.navigator.controller.reach_m
        self.points_pose = None  # the pose [m, m, rad] the cached scan points were taken at
        if p.navigation == "move_base":
            from tpuaf.ros.move_base import MoveBaseClient

            self.runtime.navigator = GoalNavigator(
                MoveBaseClient(p.move_base_action, p.map_frame), self.runtime.visit_radius,
                p.waypoint_tolerance, stuck_timeout_s=p.move_base_timeout,
                near_goal_m=self.runtime.goal_tolerance)
        if p.wait_for_start and sim:
            self.runtime.start_at = None
        self.points = None
        self._scan = None
        self._deferred = None  # lock-step: (stamp, run time) of a tick waiting for its scan
        self._stride = 1
        self.origin = odom_origin(p, patrol_map)  # odom frame in the map frame
        if p.initial_pose and p.localization in ("tf", "amcl"):
            self._initial_pose_pub = send_initial_pose(p.initial_pose, p.map_frame)

    def _subscribers(self, p: AgentParams) -> None:
        """Team messages, events, the run start, the scan, /tf_static and the pose source."""
        ns = rospy.get_namespace().strip("/")
        # every attribute the callbacks read is set first: a callback may run at once
        self.base_frame = p.base_frame or (f"{ns}/base_footprint" if ns else "base_footprint")
        self.chain = FrameChain(p.map_frame, self.base_frame) if p.localization == "tf" else None
        # The laser's mounting (base -> laser frame) from /tf_static: scan points are used in
        # the base frame, as in the physics runtime (LDS-01 on a Burger: 3.2 cm behind).
        self._statics = StaticFrames()
        self.laser_pose = None  # (x, y, yaw) of the laser in the base frame, once known
        self._laser_frame = None
        for cls, ros_cls in self.conv.types.items():
            rospy.Subscriber(topics.team_topic(p.team_ns, cls), ros_cls, self.on_team,
                             queue_size=200)
        rospy.Subscriber(topics.EVENTS_TOPIC, AgentEvent, self.on_event, queue_size=200)
        rospy.Subscriber(topics.START_TOPIC, RunStart, self.on_start, queue_size=10)
        rospy.Subscriber(topics.SCAN, numpy_msg(LaserScan), self.on_scan, queue_size=1,
                         tcp_nodelay=True)
        rospy.Subscriber("/tf_static", TFMessage, self.on_tf_static, queue_size=5)
        if p.localization == "ground_truth":
            rospy.Subscriber(topics.GROUND_TRUTH, Odometry, self.on_odom, queue_size=1,
                             tcp_nodelay=True)
        elif p.localization == "odom":
            rospy.Subscriber(topics.ODOM, Odometry, self.on_odom, queue_size=1, tcp_nodelay=True)
        elif p.localization == "tf":
            rospy.Subscriber("/tf", TFMessage, self.on_tf, queue_size=5, tcp_nodelay=True)
        else:  # amcl publishes on change only: control runs on the scans then.
            rospy.Subscriber(topics.AMCL_POSE, PoseWithCovarianceStamped, self.on_amcl,
                             queue_size=1)

    # --- time ---
    def ros_now(self) -> float:
        """[s] ROS time of this robot (wall clock + ~clock_offset, or /clock)."""
        return rospy.get_time() + self.p.clock_offset

    def run_time(self, stamp: float) -> float:
        """Run time [s] of a tick: the message stamp on /clock, our own clock otherwise (the
        pose may come from another computer whose clock differs)."""
        return (stamp if self.sim else self.ros_now()) - self.epoch

    # --- outputs ---
    def publish_team(self, message):
        if self.team_ticks is not None:
            self.team_ticks.on_sent()
        publish(self.team_pub[type(message)], self.conv.to_ros(message))

    def answer(self, stamp):
        """Lock-step: answer the tick of `stamp` (the command), then the team counts."""
        self.cmd.header.stamp = stamp
        publish(self.cmd_pub, self.cmd)
        self._answered_ns = stamp.to_nsec()
        self.publish_counts()

    def publish_counts(self):  # lock-step: the team barrier's data (tpuaf.team.lockstep)
        publish(self.counts_pub, Int64MultiArray(data=self.team_ticks.counts(self._answered_ns)))

    def publish_event(self, kind, vertex, from_vertex, t):
        e = self.event
        e.header.stamp = convert.stamp(t, self.epoch or 0.0)
        e.event = kind
        e.vertex = self.conv.vid(vertex)
        e.from_vertex = self.conv.vid(from_vertex)
        publish(self.event_pub, e)

    def stop_robot(self, stamp=None):
        self.twist.linear.x = self.twist.angular.z = 0.0
        if not self.drives:
            return
        if self.lockstep:
            if stamp is not None:  # lock-step answers ticks only
                self.answer(stamp)
            return
        publish(self.cmd_pub, self.cmd)

    def warn(self, key, text, period=WARN_PERIOD_S):
        now = time.monotonic()
        if now - self._warned.get(key, -math.inf) >= period:
            self._warned[key] = now
            rospy.logwarn(f"{self.name}: {text}")

    # --- inputs ---
    def on_start(self, msg):
        """A run start on /fleet/start (any agent's or the monitor's latched copy): the
        earliest wins; a new or earlier one is adopted and re-latched by us, so that a
        restarted or late agent finds the running start (tpuaf.team.epoch)."""
        start = convert.stamp_s(msg)
        with self.lock:
            previous = self.run_start.epoch_s
            result = self.run_start.offer(start, msg.announcer)
            if result == INVALID:
                self.warn("start", f"ignored run start {start!r} on {topics.START_TOPIC}")
                return
            if result == KEPT:
                return
            if self.sim or self.p.epoch >= 0:
                self.runtime.start_at = start - self.epoch
            else:
                if self.epoch is not None:
                    rospy.loginfo(f"{self.name}: earlier run start {start:.3f} announced; run "
                                  f"time moves forward by {self.epoch - start:.3f} s")
                self.epoch = self.conv.epoch = start
            self._latch_start()
        if previous is None:
            rospy.loginfo(f"{self.name}: run start {start:.3f} s of ROS time (announced by "
                          f"{msg.announcer or 'an unnamed node'})")

    def announce_start(self):
        """Wall clock, nobody announced a start within ~start_wait: announce ours (latched)."""
        start = float(math.floor(self.ros_now()))
        with self.lock:
            if self.epoch is not None or self.run_start.offer(start, rospy.get_name()) != ADOPTED:
                return
            self.epoch = self.conv.epoch = start
            self._latch_start()
        rospy.loginfo(f"{self.name}: announced the run start {start:.3f} s on "
                      f"{topics.START_TOPIC}")

    def _latch_start(self):
        """Latch the agreed run start on /fleet/start (with the lock held)."""
        publish(self.start_pub, convert.run_start_message(
            self.run_start.epoch_s, self.run_start.announcer, self.names))

    def on_team(self, msg):
        r = msg.robot_index
        if r == self.p.robot_index or self.epoch is None:
            return  # our own broadcast, or no clock yet
        with self.lock:
            why = self.inbox.sender_problem(r, sender_of(msg))
            if why is not None:
                self.warn(("bad", r, "sender"), f"ignored a team message from {msg.robot!r}: {why}")
                return
            if self.team_ticks is None:
                now = self.ros_now() - self.epoch
                self.handle_team(msg, now, now)
                return
            self.team_ticks.on_received(r)  # counted for the barrier, handled at the next tick
            rank = TOPIC_RANK.get(type(msg).__name__, -1)
            if not self.team_ticks.put(self.conv.time(msg), r, rank, msg):  # far ahead
                self.inbox.reject("clock")
            self.publish_counts()

    def handle_team(self, msg, now, heard):
        """A team message at run time `now` [s], its sender heard at `heard` [s] (lock held)."""
        r = msg.robot_index
        try:
            message = self.conv.from_ros(msg)
        except convert.MalformedMessage as err:
            self.inbox.reject("malformed")
            self.warn(("bad", r, _shape(str(err))),
                      f"ignored a team message from {msg.robot!r}: {err}")
            return
        message, why = self.inbox.accept(message, now)
        if message is None:
            self.warn(("bad", r, _shape(why)), f"ignored a team message from {msg.robot!r}: {why}")
            return
        if self.runtime.hear(r, heard):
            rospy.loginfo(f"{self.name}: teammate {self.names[r]} heard again")
        self.runtime.on_message(message)

    def handle_due(self, t):
        """Lock-step, before the tick at run time t [s]: the teammates' messages and events
        stamped before it, in one order (tpuaf.team.lockstep), then the liveness check."""
        self.runtime.advance(t)
        for stamp, r, msg in self.team_ticks.due(t):
            if msg is not None:
                self.handle_team(msg, t, stamp)
            elif self.runtime.hear(r, stamp):
                rospy.loginfo(f"{self.name}: teammate {self.names[r]} heard again")
        self.check_liveness(t)

    def check_liveness(self, now):  # teammates silent for the timeout: the policy is told
        for r in self.runtime.check_liveness(now):
            silent = self.liveness.silent_for(r, now)
            rospy.logwarn(f"{self.name}: teammate {self.names[r]} silent for {silent:.1f} s: "
                          "lost, its intentions dropped")

    def on_event(self, msg):
        r = msg.robot_index
        if r == self.p.robot_index or self.epoch is None or not 0 <= r < self.p.robots:
            return
        now = self.ros_now() - self.epoch
        with self.lock:
            if self.inbox.sender_problem(r, sender_of(msg)) is not None:
                return  # another node as robot r (counted)
            if self.team_ticks is not None:  # heard at its stamp, at the next tick
                if not self.team_ticks.put(convert.stamp_s(msg) - self.epoch, r, 99, None):
                    self.inbox.reject("clock")
                return
            if msg.event == topics.HEARTBEAT:  # stamped "now" (a GOAL may be post-dated)
                self.inbox.observe(r, convert.stamp_s(msg) - self.epoch, now)
            if self.runtime.hear(r, now):
                rospy.loginfo(f"{self.name}: teammate {self.names[r]} heard again")

    def report_stuck(self, goal: int, retry: int, t: float) -> None:
        """The navigator is stuck on its way (no progress for ~stuck_timeout): say so."""
        vid = self.conv.patrol_map.vertex_ids[goal]
        rospy.logwarn(f"{self.name}: stuck on the way to vertex {vid} at run time {t:.1f} s: "
                      f"backing off and replanning (recovery {retry} of {self.p.max_retries}; "
                      f"then the goal fails)")

    def on_scan(self, msg):
        self.inputs.fed("scan", msg.header.stamp.to_sec(), time.monotonic())
        with self.lock:
            self._scan = msg
            self.points = None
            if self.control_on_scan:
                self.control(msg.header.stamp)
            elif self._deferred is not None and self._deferred[0] <= msg.header.stamp:
                stamp, t = self._deferred  # lock-step: the tick that waited for this scan
                self._deferred = None
                self.control(stamp, t)

    def scan_due(self, stamp) -> bool:
        """Lock-step: does the simulator send a scan stamped `stamp` (not yet received)?
        Its scans come on pose ticks at the laser rate; the tick then waits for it, so the
        control sees the scan of its own instant, whatever order the threads run in."""
        s = self._scan
        if not self.lockstep or s is None or not s.scan_time > 0:
            return False
        return (stamp - s.header.stamp).to_sec() >= s.scan_time - 1e-3

    def on_odom(self, msg):
        pose = msg.pose.pose
        x, y, th = pose.position.x, pose.position.y, yaw_of(pose.orientation)
        if self.origin is not None:  # odom frame -> map frame
            x, y, th = compose(self.origin, (x, y, th))
        self.pose_tick(msg.header.stamp, x, y, th)

    def on_tf(self, msg):
        chain = self.chain
        base_stamp = None
        with self.lock:
            for tf in msg.transforms:
                tr = tf.transform
                if chain.update(tf.header.frame_id, tf.child_frame_id, tr.translation.x,
                                tr.translation.y, yaw_of(tr.rotation),
                                tf.header.stamp.to_sec()) and tf.child_frame_id.lstrip(
                                    "/") == chain.base:
                    base_stamp = tf.header.stamp
        if base_stamp is None:
            return
        pose = chain.pose()
        if pose is None:
            self.warn("tf", f"no tf chain {chain.root} -> {chain.base} yet (missing the parent "
                      f"of {chain.missing()}): is the localiser running?")
            return
        self.pose_tick(base_stamp, pose[0], pose[1], pose[2])

    def on_tf_static(self, msg):
        with self.lock:
            for tf in msg.transforms:
                tr = tf.transform
                self._statics.add(tf.header.frame_id, tf.child_frame_id, tr.translation.x,
                                  tr.translation.y, yaw_of(tr.rotation))
            if self.chain is not None:
                self._statics.feed(self.chain)
            if self.laser_pose is None and self._laser_frame:
                self._find_laser()

    def _find_laser(self):
        """The laser frame's pose in the base frame from the static transforms, if complete."""
        pose = self._statics.pose_in(self.base_frame, self._laser_frame)
        if pose is not None:
            self.laser_pose = pose[:3]
            self.points = None
            rospy.loginfo(f"{self.name}: laser {self._laser_frame} at x {pose[0]:+.3f} m, "
                          f"y {pose[1]:+.3f} m, yaw {pose[2]:+.3f} rad of {self.base_frame}")

    def on_amcl(self, msg):
        pose = msg.pose.pose
        self.inputs.fed("pose", msg.header.stamp.to_sec(), time.monotonic())
        if self.epoch is None:
            return
        with self.lock:
            self.runtime.on_pose(self.run_time(msg.header.stamp.to_sec()), pose.position.x,
                                 pose.position.y, yaw_of(pose.orientation))

    def pose_tick(self, stamp, x, y, th):
        """One control tick on a new pose (stamp: genpy Time of the pose)."""
        sec = stamp.to_sec()
        self.inputs.fed("pose", sec, time.monotonic())
        with self.lock:
            if self.epoch is None:
                self.stop_robot(stamp)
                return
            t = self.run_time(sec)
            if self._deferred is not None:  # its scan never came: answer it as it is
                self.control(*self._deferred)
                self._deferred = None
            self.runtime.on_pose(t, x, y, th)
            if self.scan_due(stamp):
                self._deferred = (stamp, t)  # answered when the scan of this tick arrives
                return
            self.control(stamp, t)

    def control(self, stamp, t=None):
        """Runtime tick at run time t [s] and the velocity command (caller holds the lock)."""
        if self.epoch is None:
            self.stop_robot(stamp)
            return
        if t is None:
            t = self.run_time(stamp.to_sec())
        if self.team_ticks is not None:
            self.handle_due(t)
        if self.halted:  # lock-step: the simulator waits for us; time standing still is no fault
            stale = () if self.lockstep else self.inputs.check(time.monotonic())[0]
            if stale:
                self.stop_robot(stamp)
                return
            self.resume()
        if self.points is None and self._scan is not None:  # the physics runtime's scan step
            s = self._scan
            if self.laser_pose is None and self._laser_frame != s.header.frame_id:
                self._laser_frame = s.header.frame_id
                self._find_laser()
            mount = LaserMount(*self.laser_pose) if self.laser_pose is not None else LaserMount()
            pts = scan_points(Scan(s.ranges, s.angle_min, s.angle_increment, s.range_min,
                                   s.range_max), mount, self.p.scan_beams, self.points_within_m)
            # a laser that does not see behind the robot: give way forward (navigator.py)
            nav = self.runtime.navigator
            if hasattr(nav, "sees_behind"):
                nav.sees_behind = len(s.ranges) * abs(s.angle_increment) >= FULL_CIRCLE_RAD
            self.points = pts
            self.points_pose = self.runtime.pose  # as the physics runtime: motion-compensated
        v, w = self.runtime.tick(t, self.points,
                                 self.points_pose if self.points is not None else None)
        if not self.drives:
            return
        self.twist.linear.x, self.twist.angular.z = v, w
        if self.lockstep:
            self.answer(stamp)
        else:
            publish(self.cmd_pub, self.cmd)

    # --- supervision (own thread, wall clock) ---
    def halt(self, stale):
        self.halted = True
        self.runtime.navigator.pause()
        self.stop_robot()

    def resume(self):
        self.halted = False
        if self.epoch is not None:
            self.runtime.navigator.resume(self.run_time(self.ros_now()))
        rospy.loginfo(f"{self.name}: pose, scan and clock advancing: driving")

    def supervise(self):
        """Input watchdog, run start, teammate liveness and skew warnings at 4 Hz of wall time."""
        period = 0.25
        last_clock, told = None, 0  # told: refusals published
        next_beat = 0.0
        while not rospy.is_shutdown():
            time.sleep(period)
            wall = time.monotonic()
            try:
                t = self.ros_now()
            except rospy.ROSException:
                break
            if last_clock is None or t > last_clock:
                self.inputs.fed("clock", t, wall)
                last_clock = t
            stale, changed = ((), False) if self.lockstep else self.inputs.check(wall)
            with self.lock:
                if stale and (changed or not self.halted):
                    self.halt(stale)
                elif stale:
                    self.stop_robot()
            if stale and wall - self._t0_wall > self.p.input_timeout:
                src = {"pose": self.pose_input, "scan": rospy.resolve_name(topics.SCAN),
                       "clock": "ROS time"}
                what = []
                for n in stale:
                    age = self.inputs.age(n, wall)
                    what.append(f"{n} ({src[n]}) " + (f"not advancing for {age:.1f} s"
                                                      if math.isfinite(age) else "not received"))
                self.warn("stale", f"robot stopped: {', '.join(what)}; resumes when they do")
            if self.epoch is None:
                if not self.p.wait_for_start and wall - self._t0_wall >= self.p.start_wait:
                    self.announce_start()
                else:
                    if wall >= next_beat:  # "ready" for a monitor that announces the start
                        next_beat = wall + self.p.heartbeat_period
                        e = self.event
                        e.header.stamp = rospy.Time.from_sec(max(t, 0.0))
                        e.event, e.vertex, e.from_vertex = topics.HEARTBEAT, -1, -1
                        publish(self.event_pub, e)
                    if self.p.wait_for_start:
                        self.warn("start", f"waiting for the run start on {topics.START_TOPIC}",
                                  period=30.0)
                continue
            now = t - self.epoch
            with self.lock:
                if self.team_ticks is None:  # lock-step: at the ticks (handle_due)
                    self.check_liveness(now)
                skewed = {r: o for r, o in self.inbox.skewed().items()
                          if r not in self.liveness.lost}
                if self.inbox.rejected != told:  # for the monitor's summary
                    told = self.inbox.rejected
                    publish(self.rejections_pub, convert.rejections_message(
                        self.p.robot_index, self.inbox.rejections))
            for r, offset in skewed.items():
                self.warn(("skew", r), f"clock of {self.names[r]} is {offset:+.2f} s off ours "
                          f"(from its message stamps; > {self.p.skew_warn:g} s): sync the "
                          "robots' clocks (chrony, docs/HARDWARE.md); its times are corrected",
                          period=30.0)


def main():
    rospy.init_node(NODE)
    try:
        p = parse(AgentParams, private_params(), rospy.get_name())
        sim = bool(rospy.get_param("/use_sim_time", False))
        check_agent_params(p, sim)
        patrol_map = load_map(p.map, params=p.map_params, params_origin="~map_params")
        node = AgentNode(p, patrol_map, sim)
    except (NodeParamError, MapError, ParameterError, KeyError) as err:
        return fatal(err)
    rospy.loginfo(f"{rospy.get_name()}: {p.strategy} robot {p.robot_index}/{p.robots} on "
                  f"{patrol_map.name}, localisation {node.pose_input}, navigation "
                  f"{p.navigation}, {'sim time' if sim else 'wall clock'}, epoch "
                  f"{'from ' + topics.START_TOPIC if node.epoch is None else node.epoch}")
    rospy.spin()
    return 0


def entry() -> int:
    return run_node(NODE, __doc__.splitlines()[0].split(": ", 1)[-1], AgentParams, main)
