"""Bag analysis with `rosbags` (no ROS installation needed), of a `tpuaf fleet` bag or a plain
`rosbag record` of a robot run.

Visits (docs/RUNTIMES.md "Visits"): the agents' events on /fleet/agent_events, when the bag
has them, are replayed with the robots' positions through the same `FleetMonitor` (and so the
same VisitRule and RunRecorder) as the live monitor node: START is the start vertex's first
visit, a visit a pose within the visit radius of the robot's goal (GOAL events) after it was
farther than twice the radius; DWELL events count apart. Without poses, or without the events
(the Visit team messages, /team/visits: a robot's first is its START), the agents' reports are
the visits (REACHED). Positions come from the best source the bag holds for
every robot: ground truth (/<robot>/base_pose_ground_truth), tf (map -> <robot>/base_footprint
on /tf and /tf_static), /<robot>/amcl_pose, /<robot>/odom; without any, visits and idleness are
computed and X and interference are not (the notes say so). Liveness: the agents' heartbeats.

Time: the analysed span is the bag's own (record times, shifted onto the message stamps' clock
when the recorder ran on another one): it starts at /fleet/start (a fleet bag: the run's one
start, tpuaf.team.epoch; later ones are counted refusals), at the bag's beginning plus
`start_offset_s`, or, in a bag without /fleet/start, at the agents' first report (the first
START event, else the first agent event or team message; a note says so), and ends after
`duration_s` or at the bag's end; a span outside the bag is refused. Messages are replayed in
stamp order. Agent events pass the monitor's checks (tpuaf.measure.traffic: duplicates, sender,
clock, rate; refusals counted in the summary's `rejected`). Memory: messages are streamed;
state is per robot and per vertex, plus the recorder's rows (one per second of the span).

Entry points (pure functions of a file; every problem is a BagError naming it):
`inspect(path)` -> BagInfo (tpuaf.measure.bag_info: what the bag holds) and
`analyze(path, patrol_map, ...)` -> Analysis (here: the span, the replay, the metrics). Reading
and decoding the bag: tpuaf.measure.bag_decode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tpuaf.measure.bag_decode import (
    REORDER_WINDOW_S,
    BagError,
    guarded,
    in_stamp_order,
    is_type,
    open_bag,
    raw_pose_reader,
    raw_readers,
    read_messages,
    stamp_of,
    typestore,
)
from tpuaf.measure.bag_info import (
    BASE_FRAME,
    MAP_FRAME,
    STAMP_MARGIN_S,
    TF_TOPICS,
    VISITS_BASENAME,
    BagInfo,
    inspect,
    inspect_reader,
    is_visit,
)
from tpuaf.measure.monitor import OUTAGE_SILENT, STAMP_EPS_S, FleetMonitor, with_epoch
from tpuaf.measure.poses import POSE_SOURCES, MonitorFeed, chain_pose, feed_chains, robot_chains
from tpuaf.measure.traffic import TrafficGuard
from tpuaf.params import LIVENESS_DEFAULTS
from tpuaf.team.epoch import CROSS_WINDOW_S
from tpuaf.topics import (
    AMCL_POSE,
    DEFAULT_TEAM_NS,
    EVENTS_TOPIC,
    GROUND_TRUTH,
    HEARTBEAT,
    ODOM,
    REACHED,
    START,
    START_TOPIC,
)

REORDER_MARGIN_S = 5.0  # [s] beyond the latest message measured by inspect
# a robot with fewer ground-truth poses than this share of the most (the simulator publishes
# all alike): the recorder dropped messages under load, and the analysis says so
LOST_POSES = 0.98

__all__ = ["Analysis", "BagError", "BagInfo", "analyze", "inspect", "is_visit"]


@dataclass
class Analysis:
    """The metrics of the run in a bag (analyze), with what they were computed from."""

    summary: dict
    recorder: Any  # the RunRecorder (results writer input)
    info: BagInfo
    robots: int
    start_s: float  # analysed span [s], on the messages' clock
    end_s: float
    pose_source: str | None
    visit_source: str  # "REACHED events" | "Visit team messages" | "none"
    reports: int  # visit reports inside the span
    liveness: bool  # deaths were detected from heartbeats
    notes: list[str] = field(default_factory=list)

    @property
    def span_s(self) -> float:
        return self.end_s - self.start_s


@guarded
def analyze(path: str | Path, patrol_map: Any, *, robots: int | None = None,
            start_offset_s: float | None = None, duration_s: float | None = None,
            death_timeout_s: float | None = None, pose_source: str | None = None,
            team_ns: str | None = None, teammate_timeout_s: float | None = None,
            robot_radius_m: float | None = None) -> Analysis:
    """Metrics of the run in the bag (see the module docstring).

    start_offset_s: the span starts this long after the bag's beginning (default: /fleet/start
    when the bag has it, else the beginning); duration_s: its length (default: the monitored
    run's duration when the bag holds all of it, else up to the bag's end); death_timeout_s:
    heartbeat silence that makes a robot dead (default 5 s; off without heartbeats);
    teammate_timeout_s: the agents' teammate timeout, for the recovery's floor at detection
    (default 10 s, the agents' default);
    pose_source: ground_truth | tf | amcl | odom (default: the best one the bag has);
    robot_radius_m: the robots' radius, for a dead robot's body on a vertex (the recovery over
    the reachable vertices; default: the map's robot radius)."""

    path = Path(path)
    with open_bag(path) as reader:  # one open: rosbags reads the whole index on opening
        return _analyze(path, reader, patrol_map, robots, start_offset_s, duration_s,
                        death_timeout_s, pose_source, team_ns, teammate_timeout_s,
                        robot_radius_m)


def _analyze(path, reader, patrol_map, robots, start_offset_s, duration_s, death_timeout_s,
             pose_source, team_ns, teammate_timeout_s=None, robot_radius_m=None) -> Analysis:
    info = inspect_reader(path, reader)
    notes: list[str] = []
    n = int(robots) if robots else info.robots
    if n <= 0:
        raise BagError(f"{path}: no robot found (no team messages, agent events or "
                       f"/<robot>/odom, amcl_pose, base_pose_ground_truth topics); topics: "
                       f"{', '.join(sorted(info.topics)) or 'none'}")
    if info.robots > n:
        notes.append(f"the bag has reports of {info.robots} robots; robots >= {n} ignored")
    if info.clock_offset_s:
        notes.append(f"the recorder's clock differs from the message stamps by "
                     f"{info.clock_offset_s:+.1f} s: the span is taken on the stamps' clock")
    notes += _start_notes(info, start_offset_s)
    start, end = _span(info, start_offset_s, duration_s)
    if death_timeout_s is not None and not death_timeout_s > 0:
        raise BagError(f"death timeout must be > 0 s, got {death_timeout_s:g}")
    if teammate_timeout_s is not None and not teammate_timeout_s > 0:
        raise BagError(f"teammate timeout must be > 0 s, got {teammate_timeout_s:g}")
    mate_timeout = (LIVENESS_DEFAULTS.teammate_timeout_s if teammate_timeout_s is None
                    else float(teammate_timeout_s))

    team = {t: k for t, k in info.team_topics.items()
            if team_ns is None or t.startswith(team_ns.rstrip("/") + "/")}
    visit_source = _visit_source(info, team, notes)
    liveness, timeout = _liveness(info, death_timeout_s, mate_timeout, notes)
    source = _pose_source(path, info, n, pose_source, notes)

    store = typestore(reader)
    if source is None:
        recorder, reports, guard, end = _replay_reports(path, reader, store, info, patrol_map,
                                                        n, start, end, timeout, team, liveness)
        monitor = None
    else:
        # the announced start is run time 0 itself, as in the live monitor
        exact = start_offset_s is None and start in (info.fleet_start_s, info.first_report_s)
        monitor, reports = _replay(path, reader, store, info, patrol_map, n, start, end,
                                   timeout, team, source, mate_timeout, exact, robot_radius_m)
        recorder = monitor.recorder
    if info.out_of_span:
        notes.append(f"{info.out_of_span} message(s) stamped outside the bag's span ignored")
    if monitor is not None:
        summary = monitor.summary()
        start_used = monitor.start_time
    else:
        summary = with_epoch(recorder.summary(end - start), start)
        summary.update(guard.summary())
        start_used = start
    end_used = start_used + summary["duration_s"]
    # reports inside the analysed span (a START before it is the first visit at its start)
    eps = STAMP_EPS_S
    n_reports = sum(1 for t, first in reports
                    if (first or t >= start_used - eps) and t <= end_used + eps)
    if source is None:
        for key in ("uncertainty_mean", "uncertainty_final_mean", "interferences",
                    "interference_rate_per_min"):
            summary[key] = None
    return Analysis(summary, recorder, info, n, start_used, end_used, source, visit_source,
                    n_reports, liveness, notes)


def _visit_source(info: BagInfo, team: dict[str, str], notes: list[str]) -> str:
    """Visits: START/REACHED events, else Visit team messages; the notes say which."""
    visit_topics = [t for t, k in team.items() if k == "Visit"]
    if info.visit_events:
        return f"START and REACHED events ({EVENTS_TOPIC})"
    if info.visit_messages:
        notes.append(f"visits from the Visit team messages (no START/REACHED events on "
                     f"{EVENTS_TOPIC}): a strategy that also sends one when it decides again "
                     "after a failed goal (TPUAF) counts those too; record the events for exact "
                     "counts")
        return f"Visit team messages ({', '.join(visit_topics)})"
    notes.append(f"no visit reports: neither START/REACHED events on {EVENTS_TOPIC} nor "
                 f"Visit messages on {DEFAULT_TEAM_NS}/{VISITS_BASENAME}: visits and "
                 "idleness cannot be computed")
    return "none"


def _liveness(info: BagInfo, death_timeout_s: float | None, teammate_timeout_s: float,
              notes: list[str]) -> tuple[bool, float]:
    """(deaths are judged, silence [s] that makes a robot dead): heartbeats (agent events);
    team messages only when a timeout is given. Not given, the silence is the teammate timeout:
    the monitor's rule (FleetMonitor), so that the analysis of a bag agrees with it."""
    liveness = info.events > 0 or death_timeout_s is not None
    timeout = death_timeout_s if death_timeout_s is not None else teammate_timeout_s
    if not liveness:
        timeout = math.inf
        notes.append(f"deaths not detected: no agent heartbeats ({EVENTS_TOPIC}) in the bag "
                     "(give --death-timeout to judge liveness from the team messages)")
    elif not info.events:
        notes.append(f"liveness judged from the team messages (no heartbeats on "
                     f"{EVENTS_TOPIC}): a robot silent for {timeout:g} s is dead")
    return liveness, timeout


def _pose_source(path: Path, info: BagInfo, n: int, pose_source: str | None,
                 notes: list[str]) -> str | None:
    """The pose source asked for (a BagError if the bag lacks it), else the best one the bag
    has for every robot, else None (no positions)."""
    available = info.pose_sources(n)
    if pose_source is not None:
        if pose_source not in POSE_SOURCES:
            raise BagError(f"pose source must be one of {', '.join(POSE_SOURCES)}, got "
                           f"{pose_source!r}")
        if pose_source not in available:
            raise BagError(f"{path}: no {pose_source} poses for every robot 0..{n - 1} "
                           f"(available: {', '.join(available) or 'none'})")
        source = pose_source
    else:
        source = available[0] if available else None
    if source is None:
        notes.append(_missing_poses(info, n))
    else:
        notes.append(f"positions (X, interference) from {POSE_SOURCES[source]}")
        counts = {r: info.topics.get(t, 0) for r, t in info.pose_topics.get(source, {}).items()
                  if r < n}
        if (source == "ground_truth" and counts
                and min(counts.values()) < LOST_POSES * max(counts.values())):
            notes.append("the recorder lost poses (per robot: " + ", ".join(
                f"{r}: {k}" for r, k in sorted(counts.items())) + "; all are published "
                "alike): visits may be missed where a robot's poses are missing")
    return source


def _start_notes(info: BagInfo, start_offset_s: float | None) -> list[str]:
    """Notes on the bag's run starts: several (a robot that restarted and announced a new
    run), or one outside the bag."""
    if not info.fleet_starts:
        if start_offset_s is None and info.first_report_s is not None:
            return [f"no run start on {START_TOPIC}: analysed from the agents' first report "
                    f"({info.first_report_s - info.start_s:+.1f} s from the bag's beginning; "
                    "a START event, else any agent event or team message; --start to choose)"]
        return []

    def when(s):
        by = next((a for t, a in info.fleet_starts if t == s), "")
        return f"{s - info.start_s:+.1f} s" + (f" (by {by})" if by else "")
    if info.fleet_start_s is None:
        return [f"the run start{'s' if len(info.fleet_starts) > 1 else ''} on {START_TOPIC} "
                f"({', '.join(when(s) for s, _ in info.fleet_starts)} from the bag's beginning) "
                "lie outside the bag: analysed from its beginning"]
    if len(info.fleet_starts) == 1:
        return []
    earliest = min(s for s, _ in info.fleet_starts)
    used = ("--start" if start_offset_s is not None
            else f"the earliest, {when(info.fleet_start_s)}" if info.fleet_start_s == earliest
            else f"the first announced, {when(info.fleet_start_s)} (a start more than "
                 f"{CROSS_WINDOW_S:g} s before the run's is a stray one: ignored, counted)")
    return [f"the bag holds {len(info.fleet_starts)} different run starts on {START_TOPIC} "
            f"({', '.join(when(s) for s, _ in info.fleet_starts)} from the bag's beginning; "
            f"an agent that restarted and announced a new run?): analysed from {used}"]


def _missing_poses(info: BagInfo, n: int) -> str:
    have = []
    for source in POSE_SOURCES:
        robots = info.tf_robots if source == "tf" else set(info.pose_topics.get(source, {}))
        if robots:
            have.append(f"{source} for robot(s) {sorted(robots)}")
    names = ", ".join(info.names.get(r, f"{info.prefix}{r}") for r in range(n))
    return ("X and interference not computed: no positions of every robot (" + names + ") in "
            f"the bag; looked for tf {MAP_FRAME} -> <robot>/{BASE_FRAME}, /<robot>/"
            f"{AMCL_POSE}, /<robot>/{ODOM}, /<robot>/{GROUND_TRUTH}"
            + (f"; found only {'; '.join(have)}" if have else ""))


def _span(info: BagInfo, start_offset_s: float | None, duration_s: float | None
          ) -> tuple[float, float]:
    """[start, end] [s] of the analysed span, inside the bag (else a BagError)."""
    b0, b1 = info.start_s, info.end_s
    where = f"{info.path}: the bag spans {info.span_s:.2f} s"
    if start_offset_s is not None:
        if not (math.isfinite(start_offset_s) and 0 <= start_offset_s < info.span_s):
            raise BagError(f"{where}: --start {start_offset_s:g} s is outside it (give 0 <= "
                           f"start < {info.span_s:.2f})")
        start = b0 + start_offset_s
    elif info.fleet_start_s is not None and b0 - STAMP_MARGIN_S <= info.fleet_start_s < b1:
        start = max(info.fleet_start_s, b0)
    elif not info.fleet_starts and info.first_report_s is not None and (
            b0 - STAMP_MARGIN_S <= info.first_report_s < b1):
        start = max(info.first_report_s, b0)  # no /fleet/start: the agents' first report
    else:
        start = b0
    left = b1 - start
    if duration_s is not None:
        if not (math.isfinite(duration_s) and duration_s > 0):
            raise BagError(f"--duration must be a positive number of seconds, got "
                           f"{duration_s:g}")
        if duration_s > left + 1e-6:
            raise BagError(f"{where}: --duration {duration_s:g} s from t = {start - b0:.2f} s "
                           f"runs past its end ({left:.2f} s left)")
        return start, start + duration_s
    if info.fleet_duration_s and 0 < info.fleet_duration_s <= left:
        return start, start + info.fleet_duration_s
    return start, b1


def _in_span(info: BagInfo, t: float) -> bool:
    ok = info.start_s - STAMP_MARGIN_S <= t <= info.end_s + STAMP_MARGIN_S
    if not ok:
        info.out_of_span += 1
    return ok


def _report_connections(reader: Any, info: BagInfo, team: dict[str, str]) -> list:
    conns = []
    for conn in reader.connections:
        if info.events and conn.topic == EVENTS_TOPIC and is_type(conn, "tpuaf_ros/AgentEvent"):
            conns.append(conn)
        elif conn.topic in team:
            conns.append(conn)
    return conns


class _Reports:
    """Agent events and team messages -> (robot, kind, vertex index, stamp), or None when out of
    range (unknown robot or vertex, stamp outside the bag). Without agent events, a robot's
    first Visit message is its START (the start vertex's first visit), later ones REACHED, as
    the agents send them; other team messages are signs of life (HEARTBEAT)."""

    def __init__(self, info: BagInfo, patrol_map: Any, n: int, team: dict[str, str]):
        self.info, self.map, self.n, self.team = info, patrol_map, n, team
        self.use_visits = not info.visit_events
        self.started = [False] * n
        self.off_clock: list[int] = []  # robots of the messages stamped outside the bag

    def __call__(self, conn: Any, msg: Any) -> tuple[int, int | None, int, float, int] | None:
        r = int(msg.robot_index)
        t = stamp_of(msg)
        if not 0 <= r < self.n:
            return None
        if not _in_span(self.info, t):
            self.off_clock.append(r)  # refused as off the clock (counted by the replay)
            return None
        from_vertex = -1
        if conn.topic == EVENTS_TOPIC and not self.use_visits:
            kind, vertex = int(msg.event), self.map.lookup_index(int(msg.vertex))
            from_vertex = self.map.lookup_index(int(msg.from_vertex))
            from_vertex = -1 if from_vertex is None else from_vertex
        elif conn.topic == EVENTS_TOPIC:  # events without visits (heartbeats only)
            kind, vertex = HEARTBEAT, -1
        elif self.use_visits and self.team.get(conn.topic) == "Visit":
            kind = REACHED if self.started[r] else START
            vertex = self.map.lookup_index(int(msg.vertex))
            if vertex is not None:
                self.started[r] = True
        else:  # a sign of life, only where the bag has no heartbeats (as the live monitor)
            kind, vertex = (None if self.info.events else HEARTBEAT), -1
        if vertex is None:
            return None
        return r, kind, vertex, t, from_vertex


def reorder_window(info: BagInfo) -> float:
    """[s] the replay's reorder window: rosbag's usual lag, or the latest message seen."""
    return max(REORDER_WINDOW_S, info.max_lateness_s + REORDER_MARGIN_S)


def stamp_span(info: BagInfo) -> tuple[float, float]:
    """[s] the stamps a replayed message may have (the bag's span with its margin)."""
    return info.start_s - STAMP_MARGIN_S, info.end_s + STAMP_MARGIN_S


def sender_of(conn: Any) -> str | None:
    """The node that published on a connection (its caller id), when the bag says."""
    return getattr(getattr(conn, "ext", None), "callerid", None) or None


def robot_names(info: BagInfo, n: int) -> list[str]:
    return [info.names.get(r, f"{info.prefix}{r}") for r in range(n)]


def _replay(path, reader, store, info, patrol_map, n, start, end, timeout, team, source,
            teammate_timeout_s, exact_start=False, robot_radius_m=None):
    """Reports and poses, in bag order, through a FleetMonitor."""
    monitor = FleetMonitor(patrol_map, n, end - start, start_after=start,
                           death_timeout_s=timeout, teammate_timeout_s=teammate_timeout_s,
                           visit_source="poses" if info.visit_events else "reports",
                           robot_names=robot_names(info, n), exact_start=exact_start,
                           body_radius_m=robot_radius_m)
    for _ in range(info.ignored_starts):
        monitor.reject(-1, "start")
    conns = _report_connections(reader, info, team)
    robot_of: dict[int, int] = {}
    raw_poses: dict[int, bool] = {}  # connection id -> is Odometry (read raw)
    if source == "tf":
        conns += [c for c in reader.connections if c.topic in TF_TOPICS
                  and is_type(c, "tf2_msgs/TFMessage")]
    else:
        topics = {t: r for r, t in info.pose_topics[source].items() if r < n}
        for c in reader.connections:
            if c.topic in topics:
                robot_of[c.id] = topics[c.topic]
                conns.append(c)
                if raw_pose_reader(c) is not None:
                    raw_poses[c.id] = raw_pose_reader(c)
    feed = MonitorFeed(monitor, grouped=source != "ground_truth")
    chains = robot_chains([info.names.get(r, f"{info.prefix}{r}") for r in range(n)],
                          MAP_FRAME, BASE_FRAME)
    reports: list[tuple[float, bool]] = []  # (stamp, is START) of the visit reports
    report_of = _Reports(info, patrol_map, n, team)

    raw_poses.update(raw_readers([c for c in conns if c.topic == EVENTS_TOPIC]))
    for conn, t_rec, msg in in_stamp_order(read_messages(path, reader, store, conns, raw_poses),
                                           reorder_window(info), stamp_span(info)):
        if conn.topic in TF_TOPICS:
            for r in feed_chains(chains, msg.transforms):
                pose = chain_pose(chains[r])
                if pose is not None and _in_span(info, pose[2]):
                    feed.add(r, pose[2], pose[0], pose[1])
        elif conn.id in robot_of:
            if type(msg) is tuple:  # read raw: (stamp, x, y)
                t, x, y = msg
            else:
                t, p = stamp_of(msg), msg.pose.pose.position
                x, y = p.x, p.y
            if not _in_span(info, t):
                continue
            feed.add(robot_of[conn.id], t, x, y)
        else:
            rep = report_of(conn, msg)
            if rep is None:
                continue
            r, kind, vertex, t, from_vertex = rep
            if kind is not None:
                if not monitor.on_event(r, kind, vertex, t, from_vertex, sender_of(conn),
                                        t_rec - info.clock_offset_s):
                    continue  # refused (tpuaf.measure.traffic): counted in the summary
                if is_visit(kind, vertex):
                    reports.append((t, kind == START))
            if team.get(conn.topic) == "Intention":  # for the recovery metrics
                target = patrol_map.lookup_index(int(msg.vertex))
                if target is not None and target >= 0:
                    monitor.on_announcement(r, target, t)
        if monitor.finished:
            break
    feed.close()  # up to the bag's last poses
    for r in report_of.off_clock:
        monitor.reject(r, "clock")
    if not monitor.started:
        raise BagError(f"{path}: no complete set of robot positions ({source}) between "
                       f"t = {start - info.start_s:.2f} s and the bag's end")
    if not monitor.finished:  # the bag ends within the span: metrics up to its last poses
        monitor.duration_s = max(0.0, min(monitor.now, end) - monitor.start_time)
        monitor.end(monitor.start_time + monitor.duration_s)
    return monitor, reports


def _replay_reports(path, reader, store, info, patrol_map, n, start, end, timeout, team,
                    liveness):
    """Reports only (no positions): visits and idleness straight into a RunRecorder."""
    from tpuaf.measure.metrics import RunRecorder

    recorder = RunRecorder(patrol_map, n, ground_truth=False)  # run time: 0 at `start`
    guard = TrafficGuard(n, patrol_map.num_vertices, robot_names(info, n))
    for _ in range(info.ignored_starts):
        guard.count(-1, "start")
    heard = [start] * n  # last sign of life [s]
    alive = [True] * n
    reports: list[tuple[float, bool]] = []  # (stamp, is START) of the visit reports
    report_of = _Reports(info, patrol_map, n, team)

    def deaths_until(t):
        for r in range(n):
            if alive[r] and t - heard[r] > timeout:  # an outage from the last event heard
                alive[r] = False
                recorder.record_robot_outage(r, round(heard[r] - start, 9), OUTAGE_SILENT)

    conns = _report_connections(reader, info, team)
    last = start  # [s] the last report's stamp
    for conn, _t, msg in in_stamp_order(
            read_messages(path, reader, store, conns, raw_readers(conns)), reorder_window(info),
            stamp_span(info)):
        rep = report_of(conn, msg)
        if rep is None:
            continue
        r, kind, vertex, t, from_vertex = rep
        if t > end:
            break
        last = max(last, t)
        if kind is None or (t < start and kind != START):
            continue  # no sign of life; before the run (a START is the first visit at the start)
        if guard.check(r, kind, vertex, from_vertex, t, _t - info.clock_offset_s,
                       sender_of(conn)):
            continue  # refused, counted
        t = max(t, start)
        if liveness:
            deaths_until(t)
        if liveness and not alive[r]:  # heard again: the outage ends
            alive[r] = True
            recorder.record_robot_back(r, round(t - start, 9))
        heard[r] = max(heard[r], t)
        # as FleetMonitor: a robot's reports count even if silent
        if recorder.record_event(r, kind, vertex, from_vertex, round(t - start, 9)):
            reports.append((t, kind == START))
    else:  # the bag ends within the span: up to its last report (record times may trail)
        end = min(end, last)
    for r in report_of.off_clock:
        guard.count(r, "clock")
    if liveness:
        deaths_until(end)
    recorder.finish(end - start)
    return recorder, reports, guard, end
