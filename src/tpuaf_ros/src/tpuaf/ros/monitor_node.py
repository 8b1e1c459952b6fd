"""monitor: measures a ROS run with tpuaf.measure.metrics (thin adapter, see docs/FLEET.md).

Visits: the agents' rule (tpuaf_core.VisitRule) on the poses below, against the goals of their
events (/fleet/agent_events, tpuaf_ros/AgentEvent, whose heartbeats also tell the living from
the dead; DWELL events are counted apart). Positions (X, interference) per ~pose_source:
ground_truth /<robot_prefix><i>/base_pose_ground_truth (simulation), tf (hardware: /tf and
/tf_static, map -> <robot_prefix><i>/base_footprint from any localiser), odom /<..><i>/odom or
amcl /<..><i>/amcl_pose; poses at their own stamps are grouped on 0.1 s ticks (tpuaf.measure.poses).
Publishes /fleet/start (tpuaf_ros/RunStart, latched: the run's start, ROS time [s]) once every
agent is ready (~announce_start false: follows the agents' announcement instead),
/fleet/metrics (tpuaf_ros/LiveMetrics) at 1 Hz of run time and once more with finished = true
after writing the results folder; then it exits (~exit_delay later; at the run's end on the
clock even if no pose comes to close it). Works on the wall clock (use_sim_time false) and on sim time.
Agent events are checked (tpuaf.measure.traffic: the publisher's caller id, the clock, duplicates,
rate); a run start on /fleet/start after the first is refused; refusals are counted in
/fleet/metrics and summary.json (docs/FLEET.md "Hostile traffic").
Private parameters: tpuaf.params.MonitorParams (strict).
"""

import math
import threading
import time
import warnings
from pathlib import Path

import rospy
import yaml
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from tpuaf.errors import TpuafError
from tpuaf.maps import load_map
from tpuaf.measure.monitor import FleetMonitor
from tpuaf.measure.poses import POSE_SOURCES, MonitorFeed, chain_pose, feed_chains, robot_chains
from tpuaf.params import MonitorParams, NodeParamError, parse_monitor
from tpuaf.robot.model import choose_robot
from tpuaf.ros import convert
from tpuaf.ros.node import fatal, private_params, publish, run_node, sender_of
from tpuaf.team import messages
from tpuaf.team.epoch import INVALID, KEPT, SAME_START_S, RunEpoch
from tpuaf.topics import (
    AMCL_POSE,
    GROUND_TRUTH,
    ODOM,
    REJECTIONS_TOPIC,
    START_TOPIC,
    team_topic,
)
from tpuaf_ros.msg import AgentEvent, Intention, LiveMetrics, RunStart

NODE = "monitor"
# poses queued per robot: a lock-step simulator at full speed outruns the callbacks for a while
POSE_QUEUE = 1000


warnings.filterwarnings("ignore", message="The publisher should be created with an explicit")


def run_config(p, patrol_map):
    config = {"runtime": "ros", "map": p.map, "map_name": patrol_map.name,
              "strategy": p.strategy, "robots": p.robots, "duration_s": p.duration,
              "seed": p.seed, "death_timeout_s": p.death_timeout,
              "teammate_timeout_s": p.teammate_timeout, "stuck_after_s": p.stuck_after,
              "monitor_pose_source": POSE_SOURCES[p.pose_source]}
    if p.config_file:
        extra = yaml.safe_load(Path(p.config_file).read_text()) or {}
        config.update(extra)
    return config


class MonitorNode:
    def __init__(self, p, patrol_map):
        self.p = p
        self.lock = threading.Lock()
        self.patrol_map = patrol_map
        self.names = [f"{p.robot_prefix}{i}" for i in range(p.robots)]
        # the announced start is run time 0 (exact_start): as tpuaf analyze on the bag
        self.fm = FleetMonitor(patrol_map, p.robots, p.duration, start_after=math.inf,
                               death_timeout_s=p.death_timeout,
                               teammate_timeout_s=p.teammate_timeout,
                               stuck_after_s=p.stuck_after, robot_names=self.names,
                               exact_start=True, hold_s=p.death_timeout,
                               body_radius_m=choose_robot(p.robot, patrol_map.settings,
                                                          option="~robot").radius_m,
                               safety_margin_m=p.safety_margin)
        self.metrics_pub = rospy.Publisher(convert.METRICS_TOPIC, LiveMetrics, queue_size=10,
                                           latch=True)
        self.start_pub = rospy.Publisher(START_TOPIC, RunStart, queue_size=1, latch=True)
        self.run_start = RunEpoch()
        self.msg = LiveMetrics()
        self.msg.duration = p.duration
        self.next_metrics = -math.inf
        self.announced = False
        self.done = False
        self.writer = None
        self.write_error = None  # the results folder could not be created (a full disk)
        self.config = run_config(p, patrol_map)
        self.ready = [False] * p.robots
        self.ready_wall = None
        rospy.Subscriber(convert.EVENTS_TOPIC, AgentEvent, self.on_event, queue_size=5000)
        # announced destinations: how many of a dead robot's intentions were honoured
        rospy.Subscriber(team_topic(p.team_ns, messages.Intention), Intention,
                         self.on_intention, queue_size=500)
        # followed (~announce_start false), else watched: a start not ours is counted
        rospy.Subscriber(START_TOPIC, RunStart, self.on_start, queue_size=10)
        # what the agents refused of their team traffic (summary `rejected_by_agents`)
        self.agent_rejections: dict[int, dict[str, int]] = {}
        rospy.Subscriber(REJECTIONS_TOPIC, String, self.on_rejections, queue_size=50)
        # Poses at their own stamps (all but ground truth) are grouped on ticks.
        self.feed = MonitorFeed(self.fm, grouped=p.pose_source != "ground_truth")
        if p.pose_source == "tf":
            self.chains = robot_chains(self.names, p.map_frame, p.base_frame)
            rospy.Subscriber("/tf", TFMessage, self.on_tf, queue_size=100, tcp_nodelay=True)
            rospy.Subscriber("/tf_static", TFMessage, self.on_tf, queue_size=10)
        else:
            topic, cls = {"ground_truth": (GROUND_TRUTH, Odometry), "odom": (ODOM, Odometry),
                          "amcl": (AMCL_POSE, PoseWithCovarianceStamped)}[p.pose_source]
            for i, name in enumerate(self.names):
                rospy.Subscriber(f"/{name}/{topic}", cls, self.on_pose, callback_args=i,
                                 queue_size=POSE_QUEUE, tcp_nodelay=True)

    def on_event(self, msg):
        with self.lock:
            r = msg.robot_index
            v = self.patrol_map.lookup_index(msg.vertex)  # not on the map: refused if needed
            f = self.patrol_map.lookup_index(msg.from_vertex)
            if not self.fm.on_event(r, msg.event, -1 if v is None else v,
                                    convert.stamp_s(msg), -1 if f is None else f,
                                    sender_of(msg), rospy.get_time()):
                return  # refused (tpuaf.measure.traffic): counted, reported
            if 0 <= r < len(self.ready):
                self.ready[r] = True
            self.announce_when_ready(convert.stamp_s(msg))

    def watch_start(self):
        """Wall clock, 5 Hz, until the start is announced: a lock-step simulator holds its clock
        until the start (tpuaf_stage ~start_hold), and then no event comes to announce it."""
        while not rospy.is_shutdown() and not self.announced:
            time.sleep(0.2)
            with self.lock:
                self.announce_when_ready(-math.inf)

    def announce_when_ready(self, stamp):
        """Announce the run start once every agent is ready (an event heard), the recorder
        too, and every agent listens (lock held)."""
        if not (self.p.announce_start and not self.announced and all(self.ready)
                and self.recorder_ready()):
            return
        # Let every subscriber (agents, recorder) finish connecting before the start.
        if self.ready_wall is None:
            self.ready_wall = time.monotonic()
        waited = time.monotonic() - self.ready_wall
        if waited < self.p.start_wall_delay:
            return
        if not self.agents_listening():
            if waited < self.p.start_connect_timeout:
                return
            rospy.logwarn(f"{NODE}: not every agent is connected to {START_TOPIC} after "
                          f"{waited:.0f} s; announcing the start anyway (a late agent "
                          "starts when the latched start reaches it)")
        # Never in the past of the clock nor of the poses already seen: the event that
        # made every agent ready may be stamped seconds of a fast lock-step clock ago;
        # a start already past reached the agents late, and each began the run when it
        # heard it (10-16 s after it, differently in every run: issue 33 item 7).
        message = convert.run_start_message(
            max(stamp, self.fm.now, rospy.get_time(), self.p.start_not_before)
            + self.p.start_delay, rospy.get_name(),
            self.names)
        # the start as the agents and the bag read it (the stamp's whole nanoseconds): an
        # event stamped at the start counts live as it does in `tpuaf analyze`
        start = convert.stamp_s(message)
        self.fm.start_after = start
        self.run_start.offer(start, rospy.get_name())
        publish(self.start_pub, message)
        self.announced = True
        rospy.loginfo(f"{NODE}: all {self.p.robots} agents ready, run starts at t = "
                      f"{start:.2f} s for {self.p.duration:g} s")

    def on_rejections(self, msg):
        """An agent's refusal counts, from that robot's own node only (SenderCheck)."""
        parsed = convert.parse_rejections(msg.data)
        with self.lock:
            if parsed is not None and 0 <= parsed[0] < self.p.robots and (
                    self.fm.traffic.senders.ok(parsed[0], sender_of(msg) or "?")):
                self.agent_rejections[parsed[0]] = parsed[1]

    def agents_refused(self) -> dict:
        """summary `rejected_by_agents`: total, by reason, by robot (the robot that refused)."""
        by_reason: dict[str, int] = {}
        for counts in list(self.agent_rejections.values()):
            for reason, k in counts.items():
                by_reason[reason] = by_reason.get(reason, 0) + k
        return {"total": sum(by_reason.values()), "by_reason": dict(sorted(by_reason.items())),
                "by_robot": [{"robot": r, **c} for r, c in sorted(dict(self.agent_rejections).items())]}

    def on_intention(self, msg):
        v = self.patrol_map.lookup_index(msg.vertex)
        if v is not None and v >= 0:
            with self.lock:
                self.fm.on_announcement(msg.robot_index, v, convert.stamp_s(msg))

    def on_start(self, msg):
        """~announce_start false: the run starts at the earliest start the agents announce
        (every agent re-latches the one it keeps: tpuaf.team.epoch); a start after the one
        kept (or, announcing, any start not ours) is refused and counted."""
        start = convert.stamp_s(msg)
        with self.lock:
            if self.p.announce_start:
                if sender_of(msg) != rospy.get_name() and not (
                        self.run_start.known
                        and abs(start - self.run_start.epoch_s) <= SAME_START_S):
                    self.refuse_start(start, msg)
                return
            ignored = self.run_start.ignored
            result = self.run_start.offer(start, msg.announcer)
            if result == INVALID or self.run_start.ignored > ignored or (
                    result != KEPT and self.fm.started):
                self.refuse_start(start, msg)
                return
            if result == KEPT or self.fm.started:
                return
            self.fm.start_after = start
            self.announced = True
            rospy.loginfo(f"{NODE}: run starts at t = {start:.2f} s (announced on "
                          f"{START_TOPIC} by {msg.announcer or 'an unnamed node'}) for "
                          f"{self.p.duration:g} s")

    def refuse_start(self, start, msg):
        """A run start refused: counted with the refused traffic (with the lock held)."""
        self.fm.reject(-1, "start")
        rospy.logwarn(f"{NODE}: ignored run start {start!r} on {START_TOPIC} from "
                      f"{sender_of(msg) or 'an unknown node'} (announcer "
                      f"{msg.announcer or 'unnamed'}): one start per run")

    def agents_listening(self) -> bool:
        """Is every agent (a node in /<robot_prefix><i>/) connected to our /fleet/start? Then a
        start published now reaches it at once. Under load a connection still being set up got
        the latched start seconds of wall time late, while lock-step sim time ran on (a 30 s
        run was over before the agents started)."""
        try:
            callers = {str(info[1]) for info in self.start_pub.impl.get_stats_info()}
        except Exception:  # noqa: BLE001 - rospy internals: do not hold the start on them
            return True
        return all(any(c.startswith(f"/{name}/") for c in callers) for name in self.names)

    def recorder_ready(self):
        if not self.p.recorder_node:
            return True
        try:
            _, subs, _ = rospy.get_master().getSystemState()[2]
        except Exception:  # noqa: BLE001 - the master answers slowly: try on the next event
            return False
        # the recorder itself (~recorder_node), not just any subscriber: the agents
        # subscribe to the events too, and a start announced before the recorder listens is
        # missing from the bag
        for topic, nodes in subs:
            if topic == convert.EVENTS_TOPIC:
                recorder = self.p.recorder_node.rsplit("/", 1)[-1]
                return any(n.rsplit("/", 1)[-1] == recorder for n in nodes)
        return False

    def on_pose(self, msg, i):
        pos = msg.pose.pose.position
        with self.lock:
            self.pose(i, msg.header.stamp.to_sec(), pos.x, pos.y)

    def on_tf(self, msg):
        with self.lock:
            for r in feed_chains(self.chains, msg.transforms):
                pose = chain_pose(self.chains[r])
                if pose is not None:
                    self.pose(r, pose[2], pose[0], pose[1])

    def pose(self, i, t, x, y):
        """Robot i at (x, y) [m] at ROS time t [s] (called with the lock held)."""
        if self.done:
            return
        self.feed.add(i, t, x, y)
        for line in self.fm.news:
            rospy.logwarn(f"{NODE}: {line}")
        self.fm.news.clear()
        if not self.fm.started:
            return
        if self.writer is None and self.write_error is None:
            self.open_results()
        if self.fm.finished:
            self.finish()
        elif self.fm.now >= self.next_metrics:
            self.publish_metrics()
            self.next_metrics = self.fm.now + 1.0
            if self.writer is not None:
                self.writer.sync(self.fm.recorder)

    def open_results(self):
        if self.p.out:
            from tpuaf.experiments.results import ResultsWriter

            self.config["start_time_s"] = self.fm.start_time
            try:
                self.writer = ResultsWriter(self.p.out, self.config)
            except (OSError, TpuafError) as err:  # a full disk: measured on, written never
                self.write_error = f"{self.p.out}: {getattr(err, 'strerror', None) or err}"
                rospy.logerr(f"{NODE}: cannot write the results: {self.write_error}")

    def publish_metrics(self, finished=False):
        m = self.msg
        m.header.stamp = rospy.Time.from_sec(max(self.fm.now, 0.0))
        for key, value in self.fm.live().items():
            setattr(m, key, value)
        m.finished = finished
        publish(self.metrics_pub, m)

    def finish(self, interrupted=False):
        if self.done:
            return
        self.done = True
        if interrupted:
            with self.lock:
                self.feed.close()  # up to the last poses (the monitor runs lag_s behind)
        if self.fm.started:
            summary = self.fm.summary()
            summary["rejected_by_agents"] = self.agents_refused()  # (finish may hold the lock)
            self.write_results(summary, interrupted)
            self.publish_metrics(finished=not interrupted)
            rospy.loginfo(f"{NODE}: run {'interrupted' if interrupted else 'finished'}: "
                          f"{summary['visits']} visits, I_avg = {summary['idleness_avg_s']} s, "
                          f"deaths {summary['deaths']}"
                          + (f"; results in {self.p.out}" if self.p.out else ""))
            refused = summary["rejected"]
            if refused["total"]:
                (rospy.logwarn if summary["suspect_traffic"] else rospy.loginfo)(
                    f"{NODE}: refused {refused['total']} agent message(s) ("
                    + ", ".join(f"{k} {v}" for k, v in refused["by_reason"].items()) + ")"
                    + ("; suspect traffic: the figures may be affected"
                       if summary["suspect_traffic"] else ""))
        if not interrupted:  # the run is over: exit (on hardware nothing else stops us)
            rospy.loginfo(f"{NODE}: exiting in {self.p.exit_delay:g} s")
            timer = threading.Timer(self.p.exit_delay, rospy.signal_shutdown,
                                    args=("run finished",))
            timer.daemon = True
            timer.start()

    def write_results(self, summary, interrupted):
        """The results folder's end files; a failure (a full disk) is one error line and a
        summary.json saying "complete": false (or none, if even that does not fit)."""
        from tpuaf.experiments.run_files import write_summary

        try:
            if self.writer is not None:
                self.writer.finish(summary, self.fm.recorder, interrupted=interrupted)
            elif self.write_error is not None:
                write_summary(Path(self.p.out), {**summary, "complete": False,
                                                 "write_error": self.write_error})
        except (OSError, TpuafError) as err:
            rospy.logerr(f"{NODE}: {' '.join(str(err).split())}")

    def on_timer(self, _event=None):
        """The run's end passed and no pose came to close it (every robot silent, tf gone):
        finish on the clock (1 Hz), after the end's hold for late visits (FleetMonitor)."""
        fm = self.fm
        if self.done or not fm.started:
            return
        if rospy.get_time() < fm.start_time + fm.duration_s + fm.lag_s + fm.hold_s + 2.0:
            return
        with self.lock:
            self.feed.close()
            if not fm.finished:
                fm.end(fm.start_time + fm.duration_s)
            if self.writer is None:
                self.open_results()
            self.finish()


def main():
    rospy.init_node(NODE)
    try:
        p = parse_monitor(private_params(), rospy.get_name())
        if p.pose_source not in POSE_SOURCES:
            raise NodeParamError("~pose_source must be one of "
                                 f"{', '.join(POSE_SOURCES)}, got {p.pose_source!r}")
        if p.robots < 1 or not p.duration > 0 or not p.death_timeout > 0:
            raise NodeParamError("~robots >= 1, ~duration > 0 and "
                                 f"~death_timeout > 0 needed, got {p.robots}, {p.duration:g}, "
                                 f"{p.death_timeout:g}")
        patrol_map = load_map(p.map, params=p.map_params, params_origin="~map_params")
        node = MonitorNode(p, patrol_map)
    except (TpuafError, OSError, yaml.YAMLError) as err:  # params, map, robot preset
        return fatal(err)
    rospy.on_shutdown(lambda: node.finish(interrupted=True))
    rospy.Timer(rospy.Duration(1.0), node.on_timer)
    if p.announce_start:
        threading.Thread(target=node.watch_start, daemon=True).start()
    rospy.spin()
    return 0


def entry() -> int:
    return run_node(NODE, __doc__.splitlines()[0].split(": ", 1)[-1], MonitorParams, main)
