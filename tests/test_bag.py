"""`tpuaf analyze` on plain bags (as `rosbag record` writes them) built here with the `rosbags`
writer: team topics plus tf, odom or amcl_pose, no ground truth and no monitor topics.

`PlainBag` is also the bag builder of the bag-reader fuzz tests."""

from __future__ import annotations

import json
import math
import subprocess
import tracemalloc
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from tpuaf.maps import load_map
from tpuaf.measure.bag import BagError, analyze, inspect

REPO = Path(__file__).resolve().parents[1]
MSG_DIR = REPO / "src" / "tpuaf_ros" / "msg"
MSG_V1_DIR = REPO / "tests" / "data" / "msg_v1"  # the definitions of bags recorded before 2
TPUAF = [str(REPO / ".venv" / "bin" / "tpuaf")]
T0 = 1_700_000_000.0  # [s] wall-clock stamps, as on hardware


def typestore(version: int = 2):
    """ROS 1 Noetic types plus tpuaf_ros's, from the package's .msg files (version 2) or the
    version 1 definitions (bare `time stamp`, run start as std_msgs/Float64)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    types = {}
    for f in sorted((MSG_DIR if version == 2 else MSG_V1_DIR).glob("*.msg")):
        types.update(get_types_from_msg(f.read_text(), f"tpuaf_ros/msg/{f.stem}"))
    if "tf2_msgs/msg/TFMessage" not in store.types:
        types.update(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                        "tf2_msgs/msg/TFMessage"))
    store.register(types)
    return store


@dataclass
class PlainBag:
    """A simulated robot run written as a plain bag: robot r walks `routes[r]` (vertex
    indices) at `speed` m/s; each arrival is a Visit team message (and a REACHED event when
    `events`); poses at `rate` Hz on tf (map -> r/odom -> r/base_footprint), odom or
    amcl_pose."""

    patrol_map: object
    routes: list[list[int]]
    speed: float = 2.0  # [m/s]
    rate: float = 10.0  # [Hz]
    poses: str = "tf"  # tf | odom | amcl | none
    events: bool = False  # /fleet/agent_events too (START/REACHED/GOAL + 1 Hz heartbeats)
    visit_events: bool = True  # with events: START/REACHED among them (else heartbeats only)
    t0: float = T0
    prefix: str = "tb3_"
    silent_after: dict = field(default_factory=dict)  # robot -> [s] it stops talking and moving
    silent_between: dict = field(default_factory=dict)  # robot -> ([s], [s]): a restart
    msg_version: int = 2  # 1: as recorded before the messages had a std_msgs/Header
    starts: tuple = (0.0,)  # run starts on /fleet/start [s after t0] (several: a restart)
    visits: list = field(default_factory=list)  # (t, robot, vertex index) written
    lead_s: float = 0.0  # [s] poses and heartbeats recorded this long before the run
    duplicate: bool = False  # every message written twice (a bag merged with itself)
    # robot -> [s]: its team messages and events recorded this late (out of bag-time order)
    record_delay: dict = field(default_factory=dict)
    # (t [s], robot, vertex index): VERTEX_CLOSED events (a survivor reports a vertex cut off
    # by a lost teammate's body), with events
    closed: list = field(default_factory=list)

    def trajectory(self, r: int):
        """Piecewise-linear (t, x, y) knots of robot r and its arrivals (t, vertex)."""
        pos = np.asarray(self.patrol_map.positions, dtype=float)
        route = self.routes[r]
        t = self.t0 + 0.5
        # the agent's START: the start vertex's first visit (a Visit message too)
        knots, arrivals = [(self.t0, *pos[route[0]])], [(self.t0 + 0.25, route[0])]
        for a, b in zip(route, route[1:], strict=False):
            knots.append((t, *pos[a]))
            t += float(np.hypot(*(pos[b] - pos[a]))) / self.speed
            knots.append((t, *pos[b]))
            arrivals.append((t, b))
            t += 1.0  # dwell
        return np.array(knots), arrivals

    def write(self, path: Path) -> Path:
        from rosbags.rosbag1 import Writer

        store = typestore(self.msg_version)
        T = store.types
        tracks = [self.trajectory(r) for r in range(len(self.routes))]
        end = max(k[-1][0] for k, _ in tracks) + 2.0
        items = []  # (t, topic, message)
        for r, (knots, arrivals) in enumerate(tracks):
            items += self._team_items(T, r, arrivals, end)
            if self.poses != "none":
                items += self._pose_items(T, r, knots, end)
        items += self._start_items(T)
        if self.duplicate:
            items += list(items)
        items.sort(key=lambda item: item[0])
        path = Path(path)
        with Writer(path) as writer:
            conns = {}
            for t, topic, msg in items:
                if topic not in conns:
                    conns[topic] = writer.add_connection(topic, msg.__msgtype__, typestore=store)
                writer.write(conns[topic], int(round(t * 1e9)),
                             store.serialize_ros1(msg, msg.__msgtype__))
        return path

    @staticmethod
    def _stamp(T, t):
        sec = int(math.floor(t))
        return T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9)))

    @classmethod
    def _header(cls, T, t, frame):
        return T["std_msgs/msg/Header"](seq=0, stamp=cls._stamp(T, t), frame_id=frame)

    def _silent(self, r, t):
        t0, t1 = self.silent_between.get(r, (math.inf, math.inf))
        return t >= self.silent_after.get(r, math.inf) or t0 <= t < t1

    def _team_msg(self, T, kind, t, **fields):
        """A tpuaf_ros message stamped t: a header (version 2) or a bare stamp (1)."""
        when = ({"header": self._header(T, t, "")} if self.msg_version == 2
                else {"stamp": self._stamp(T, t)})
        return T[f"tpuaf_ros/msg/{kind}"](**when, **fields)

    def _team_items(self, T, r, arrivals, end):
        """Robot r's Visit and Intention messages, and its agent events when `events`."""
        ids = [int(v) for v in self.patrol_map.vertex_ids]
        name, items = f"{self.prefix}{r}", []
        for k, (t, v) in enumerate(arrivals):
            if self._silent(r, t):
                continue
            nxt = arrivals[k + 1][1] if k + 1 < len(arrivals) else -1
            items.append((t, "/team/visits", self._team_msg(
                T, "Visit", t, robot=name, robot_index=r, vertex=ids[v],
                next_vertex=ids[nxt] if nxt >= 0 else -1)))
            self.visits.append((t, r, v))
            if nxt >= 0:
                items.append((t + 0.01, "/team/intentions", self._team_msg(
                    T, "Intention", t + 0.01, robot=name, robot_index=r, from_vertex=ids[v],
                    vertex=ids[nxt], expected_arrival=t + 5.0, travel_time=5.0)))
            if self.events and self.visit_events:  # START (0), then REACHED (2); GOAL (1)
                items.append((t, "/fleet/agent_events", self._team_msg(
                    T, "AgentEvent", t, robot=name, robot_index=r, event=0 if k == 0 else 2,
                    vertex=ids[v], from_vertex=-1)))
                if nxt >= 0:
                    items.append((t, "/fleet/agent_events", self._team_msg(
                        T, "AgentEvent", t, robot=name, robot_index=r, event=1,
                        vertex=ids[nxt], from_vertex=ids[v])))
        if self.events:
            items += [(t, "/fleet/agent_events", self._team_msg(
                T, "AgentEvent", t, robot=name, robot_index=r, event=10, vertex=ids[v],
                from_vertex=-1)) for t, robot, v in self.closed if robot == r]
            for t in np.arange(self.t0 - self.lead_s, end, 1.0):
                if not self._silent(r, t):
                    items.append((t, "/fleet/agent_events", self._team_msg(
                        T, "AgentEvent", t, robot=name, robot_index=r, event=4, vertex=-1,
                        from_vertex=-1)))
        late = self.record_delay.get(r, 0.0)
        return [(t + late, topic, msg) for t, topic, msg in items]

    def _pose_items(self, T, r, knots, end):
        """Robot r's poses at `rate` Hz (amcl: 2 Hz) on tf, odom or amcl_pose."""
        name, items = f"{self.prefix}{r}", []
        for t in np.arange(self.t0 - self.lead_s, end, 1.0 / self.rate):
            if self._silent(r, t):
                continue
            x = float(np.interp(t, knots[:, 0], knots[:, 1]))
            y = float(np.interp(t, knots[:, 0], knots[:, 2]))
            if self.poses == "tf":
                # odom origin at (1, -1) in map; base in odom
                items.append((t, "/tf", T["tf2_msgs/msg/TFMessage"](transforms=[
                    self._tf(T, self._header(T, t, f"{name}/odom"), f"{name}/base_footprint",
                             x - 1.0, y + 1.0),
                    self._tf(T, self._header(T, t, "map"), f"{name}/odom", 1.0, -1.0)])))
            elif self.poses == "odom":
                items.append((t, f"/{name}/odom",
                              self._odom(T, self._header(T, t, f"{name}/odom"), x, y)))
            elif self.poses == "amcl":
                if round(t * self.rate) % 5 == 0:  # 2 Hz
                    p = T["geometry_msgs/msg/PoseWithCovariance"](
                        pose=self._pose(T, x, y), covariance=np.zeros(36))
                    items.append((t, f"/{name}/amcl_pose",
                                  T["geometry_msgs/msg/PoseWithCovarianceStamped"](
                                      header=self._header(T, t, "map"), pose=p)))
        return items

    def _start_items(self, T):
        """The first agent's run start (wall clock), latched on /fleet/start; a restarted
        agent of version 1 announced a new one."""
        n, items = len(self.routes), []
        for k, offset in enumerate(self.starts):
            epoch = self.t0 + offset
            if self.msg_version == 1:
                start = T["std_msgs/msg/Float64"](data=epoch)
            else:
                start = T["tpuaf_ros/msg/RunStart"](
                    header=self._header(T, epoch, ""),
                    announcer=f"/{self.prefix}{k}/patrol_agent",
                    robots=n, team=[f"{self.prefix}{i}" for i in range(n)])
            items.append((epoch + 0.1, "/fleet/start", start))
        return items

    @staticmethod
    def _pose(T, x, y):
        return T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))

    @classmethod
    def _odom(cls, T, hdr, x, y):
        twist = T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](
                linear=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)),
            covariance=np.zeros(36))
        pose = T["geometry_msgs/msg/PoseWithCovariance"](pose=cls._pose(T, x, y),
                                                         covariance=np.zeros(36))
        return T["nav_msgs/msg/Odometry"](header=hdr, child_frame_id="base_footprint",
                                          pose=pose, twist=twist)

    @staticmethod
    def _tf(T, hdr, child, x, y):
        return T["geometry_msgs/msg/TransformStamped"](
            header=hdr, child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.0),
                rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))


GRID = load_map("grid")
ROUTES = [[0, 1, 2, 7, 12, 11, 10, 5, 0, 1], [24, 23, 22, 17, 12, 13, 14, 19, 24, 23]]


def plain_bag(tmp_path, name="run.bag", **kw) -> PlainBag:
    spec = PlainBag(GRID, ROUTES, **kw)
    spec.write(tmp_path / name)
    return spec


@pytest.mark.parametrize("poses, events", [("tf", False), ("odom", False), ("amcl", False),
                                           ("none", False), ("tf", True), ("none", True), ("odom", "heartbeats")])
def test_visits_equal_the_reports_whatever_the_pose_source(tmp_path, poses, events):
    spec = plain_bag(tmp_path, poses=poses, events=bool(events),
                     visit_events=events != "heartbeats")
    result = analyze(tmp_path / "run.bag", GRID)
    s = result.summary
    reported = len(spec.visits)
    assert reported == 20  # 2 starts + 18 arrivals
    assert result.reports == reported
    assert s["visits"] == reported  # the visits are the reports, robot by robot
    by_robot = [sum(1 for _, r, _ in spec.visits if r == k) for k in (0, 1)]
    recorded = [sum(1 for _, r, _ in result.recorder.visits if r == k) for k in (0, 1)]
    assert recorded == by_robot
    assert s["idleness_avg_s"] > 0 and s["deaths"] == 0
    if poses == "none":
        assert result.pose_source is None and s["uncertainty_mean"] is None
        assert any("X and interference not computed" in n for n in result.notes)
    else:
        assert result.pose_source == poses
        assert 0 < s["uncertainty_mean"] < 1
        assert any(poses.replace("amcl", "amcl_pose") in n for n in result.notes)
    assert result.liveness == bool(events)
    assert any("deaths not detected" in n for n in result.notes) != bool(events)
    assert ("REACHED events" in result.visit_source) == (events is True)


def test_tf_chain_is_composed_and_span_is_the_bags(tmp_path):
    plain_bag(tmp_path, poses="tf")
    info = inspect(tmp_path / "run.bag")
    assert info.robots == 2 and info.tf_robots == {0, 1} and info.prefix == "tb3_"
    result = analyze(tmp_path / "run.bag", GRID)
    assert result.start_s >= info.start_s and result.end_s <= info.end_s + 1e-6
    assert result.summary["duration_s"] <= info.span_s + 1e-6
    # the recorded positions are the map-frame ones (odom origin composed)
    assert result.summary["interferences"] >= 0


def test_start_and_duration_inside_the_bag(tmp_path):
    spec = plain_bag(tmp_path, poses="tf", events=True)
    info = inspect(tmp_path / "run.bag")
    result = analyze(tmp_path / "run.bag", GRID, start_offset_s=5.0, duration_s=20.0)
    assert result.summary["duration_s"] == pytest.approx(20.0, abs=0.2)
    inside = [v for v in spec.visits if info.start_s + 5.0 <= v[0] <= info.start_s + 25.0]
    # each robot's START (before the span) is its first visit at the span's start, as in the
    # monitor
    assert result.reports == len(inside) + 2
    assert result.summary["visits"] == result.reports
    with pytest.raises(BagError, match="runs past its end"):
        analyze(tmp_path / "run.bag", GRID, duration_s=1e9)
    with pytest.raises(BagError, match="outside it"):
        analyze(tmp_path / "run.bag", GRID, start_offset_s=info.span_s + 1)
    with pytest.raises(BagError, match="death timeout"):
        analyze(tmp_path / "run.bag", GRID, death_timeout_s=0.0)


def test_heartbeats_detect_a_silent_robot(tmp_path):
    plain_bag(tmp_path, poses="tf", events=True, silent_after={1: T0 + 20.0})
    result = analyze(tmp_path / "run.bag", GRID)
    assert result.liveness and result.summary["deaths"] == 1
    assert result.summary["dead_robots"] == [1]
    # its announced intentions (Intention messages) are in the recovery metrics
    (rec,) = result.summary["recovery"]
    assert rec["robot"] == 1 and rec["intentions"] == [14]


@pytest.mark.parametrize("poses", ["tf", "none"])
def test_a_vertex_a_robot_reports_closed_stays_in_the_figures(tmp_path, poses):
    # robot 1 dies at 20 s on the grid's open floor; robot 0 reports vertex 14 cut off. The
    # report is listed, never believed: the figures leave out only what the bodies cut off in
    # truth (nothing here), and with poses the report is named a misjudgement
    plain_bag(tmp_path, poses=poses, events=True, silent_after={1: T0 + 20.0},
              closed=[(T0 + 32.0, 0, 14)])
    s = analyze(tmp_path / "run.bag", GRID).summary
    vertex = int(GRID.vertex_ids[14])
    assert s["dead_robots"] == [1] and s["lane_vertices_closed"] == [vertex]
    assert "vertices_under_bodies" not in s
    assert "worst_idleness_after_reachable_s" not in s["recovery"][0]
    assert s.get("closed_but_reachable") == ([vertex] if poses == "tf" else None)
    plain_bag(tmp_path, name="plain.bag", poses=poses, events=True,
              silent_after={1: T0 + 20.0})
    plain = analyze(tmp_path / "plain.bag", GRID).summary
    assert "lane_vertices_closed" not in plain
    assert plain["recovery"][0]["worst_idleness_after_s"] == s["recovery"][0][
        "worst_idleness_after_s"]


def test_a_robot_silent_then_heard_again_is_an_outage_not_a_death(tmp_path):
    # silent 14 s (> the 10 s timeout), then heard again, as a restarted agent
    spec = plain_bag(tmp_path, poses="tf", events=True, silent_between={1: (T0 + 8.0, T0 + 22.0)})
    result = analyze(tmp_path / "run.bag", GRID)
    s = result.summary
    assert any(r == 1 and t > T0 + 22.0 for t, r, _ in spec.visits)  # it visits again
    assert s["deaths"] == 0 and s["dead_robots"] == [] and "recovery" not in s, s
    (gap,) = s["outages"]
    assert gap["robot"] == 1 and gap["end_s"] is not None and gap["cause"] == "silent"
    assert 6.0 <= gap["start_s"] <= 8.0 and 22.0 <= gap["end_s"] <= 23.0, gap


def cli(*args, cwd=REPO):
    return subprocess.run([*TPUAF, "analyze", *map(str, args)], capture_output=True, text=True,
                          timeout=120, cwd=cwd)


def test_cli_on_a_plain_bag_writes_results_and_names_the_span(tmp_path):
    spec = plain_bag(tmp_path, poses="odom")
    out = tmp_path / "res"
    proc = cli(tmp_path / "run.bag", "--map", "grid", "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert "analysed" in proc.stdout and "of the bag's" in proc.stdout
    assert "odom (dead reckoning" in proc.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["analysis"]["visit_reports"] == len(spec.visits)
    assert summary["analysis"]["pose_source"] == "odom"
    assert summary["duration_s"] <= summary["analysis"]["bag_span_s"] + 1e-6
    for name in ("visits.csv", "timeseries.csv", "config.yaml"):
        assert (out / name).is_file()


@pytest.mark.parametrize("args, message", [
    (["--duration", "1e9"], "runs past its end"),
    (["--duration", "-5"], "--duration must be"),
    (["--duration", "nan"], "--duration must be"),
    (["--death-timeout", "-1"], "--death-timeout must be"),
    (["--death-timeout", "0"], "--death-timeout must be"),
    (["--teammate-timeout", "-1"], "--teammate-timeout must be"),
    (["--teammate-timeout", "nan"], "--teammate-timeout must be"),
    (["--start", "-1"], "--start must be"),
    (["--start", "1e6"], "outside it"),
])
def test_cli_refuses_spans_outside_the_bag(tmp_path, args, message):
    plain_bag(tmp_path, poses="none")
    proc = cli(tmp_path / "run.bag", "--map", "grid", "--out", tmp_path / "res", *args)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], proc.stderr
    assert not (tmp_path / "res" / "summary.json").exists()


@pytest.mark.parametrize("damage", ["truncate", "garble", "empty", "text"])
def test_damaged_bags_are_one_line_errors(tmp_path, damage):
    plain_bag(tmp_path, poses="tf")
    bag = tmp_path / "run.bag"
    data = bag.read_bytes()
    if damage == "truncate":
        bag.write_bytes(data[: len(data) * 2 // 3])
    elif damage == "garble":
        rng = np.random.default_rng(1)
        b = bytearray(data)
        for i in rng.integers(4096, len(b), 200):
            b[i] ^= 0xFF
        bag.write_bytes(bytes(b))
    elif damage == "empty":
        bag.write_bytes(b"")
    else:
        bag.write_text("not a bag\n")
    proc = cli(bag, "--map", "grid", "--out", tmp_path / "res")
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert str(bag) in proc.stderr


def test_a_bag_without_team_topics_names_what_is_missing(tmp_path):
    from rosbags.rosbag1 import Writer

    store = typestore()
    T = store.types
    with Writer(tmp_path / "chatter.bag") as w:
        c = w.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        for k in range(5):
            w.write(c, int((T0 + k) * 1e9), store.serialize_ros1(
                T["std_msgs/msg/String"](data="hi"), "std_msgs/msg/String"))
    proc = cli(tmp_path / "chatter.bag", "--map", "grid")
    assert proc.returncode == 2
    assert "no robot found" in proc.stderr and "/chatter" in proc.stderr


def test_memory_stays_bounded_on_a_long_bag(tmp_path):
    """The analysis streams: memory grows with the recorder's 1 Hz rows, not the messages."""
    routes = [[0, 1, 2, 3, 4, 9, 14, 19, 24, 23, 22, 21, 20, 15, 10, 5] * 3, ROUTES[1] * 6]
    spec = PlainBag(GRID, routes, poses="tf", rate=20.0)
    spec.write(tmp_path / "long.bag")
    tracemalloc.start()
    analyze(tmp_path / "long.bag", GRID)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    info = inspect(tmp_path / "long.bag")
    n_msgs = sum(info.topics.values())
    assert n_msgs > 9_000
    # measured: 4 MB for 9,400 messages (230 s), 8 MB for 37,700 (920 s)
    assert peak < 25e6, f"peak {peak / 1e6:.1f} MB for {n_msgs} messages"


def test_pose_sampler_groups_robots_on_ticks_and_a_far_stamp_cannot_flood():
    from tpuaf.measure.poses import PoseSampler

    s = PoseSampler(2, period_s=0.1, lag_s=0.5)
    ticks = []
    poses = sorted([(10.0 + k / 30, 0, float(k), 0.0) for k in range(60)]  # 30 Hz
                   + [(10.02 + k / 20, 1, 0.0, float(k)) for k in range(40)])  # 20 Hz, phase
    for t, r, x, y in poses:  # in time order, as in a bag
        s.add(r, t, x, y)
        ticks += list(s.ticks())
    times = [t for t, _ in ticks]
    assert times == sorted(times) and len(set(times)) == len(times)
    assert times[0] >= 10.02 and all(abs(t * 10 - round(t * 10)) < 1e-6 for t in times)
    for t, p in ticks:  # sample and hold: the latest pose at or before the tick
        assert p[0, 0] == int(np.floor((t - 10.0) * 30 + 1e-6))
        assert p[1, 1] == int(np.floor((t - 10.02) * 20 + 1e-6))
    s.add(0, 1e9, 0.0, 0.0)
    assert len(list(s.ticks(flush=True))) < 20  # the remaining data, not 1e10 ticks


def test_messages_of_another_definition_are_one_line_errors_or_ignored(tmp_path):
    """A foreign type on a fleet topic is ignored; a tpuaf_ros/Visit of another definition
    (an older package) is a BagError naming the topic."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg("time stamp\nstring robot\nint64 vertex",
                                      "tpuaf_ros/msg/Visit"))
    T = store.types
    with Writer(tmp_path / "old.bag") as w:
        start = w.add_connection("/fleet/start", "std_msgs/msg/String", typestore=store)
        w.write(start, int(T0 * 1e9), store.serialize_ros1(T["std_msgs/msg/String"](data="x"),
                                                           "std_msgs/msg/String"))
        c = w.add_connection("/team/visits", "tpuaf_ros/msg/Visit", typestore=store)
        for k in range(3):
            sec = int(T0) + k
            msg = T["tpuaf_ros/msg/Visit"](
                stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=0), robot="r0",
                vertex=k)
            w.write(c, sec * 10**9, store.serialize_ros1(msg, "tpuaf_ros/msg/Visit"))
    with pytest.raises(BagError, match=r"a message on /team/visits \(tpuaf_ros/msg/Visit"):
        analyze(tmp_path / "old.bag", GRID)
    proc = cli(tmp_path / "old.bag", "--map", "grid", "--out", tmp_path / "res")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


@pytest.mark.parametrize("poses", ["odom", "amcl"])
def test_poses_read_raw_equal_rosbags_deserialisation(tmp_path, poses):
    """The analysis reads Odometry and PoseWithCovarianceStamped poses from their bytes (the
    standard definitions only): the same stamps and positions as rosbags' deserialiser."""
    from rosbags.rosbag1 import Reader
    from tpuaf.measure.bag_decode import raw_pose, raw_pose_reader

    plain_bag(tmp_path, poses=poses)
    store = typestore()
    checked = 0
    with Reader(tmp_path / "run.bag") as reader:
        for conn, _t, raw in reader.messages():
            odometry = raw_pose_reader(conn)
            if odometry is None:
                continue
            msg = store.deserialize_ros1(raw, conn.msgtype)
            st, p = msg.header.stamp, msg.pose.pose.position
            assert raw_pose(raw, odometry) == (st.sec + st.nanosec * 1e-9, p.x, p.y)
            checked += 1
    assert checked > 100
    # another definition of the same type name is not read raw
    assert raw_pose_reader(type("C", (), {"msgtype": "nav_msgs/msg/Odometry",
                                          "digest": "0" * 32})()) is None


def test_messages_come_in_rosbags_order_with_the_same_bytes(tmp_path):
    """The analysis' own index walk (tpuaf.measure.bag_decode.index_messages) yields what
    rosbags' Reader.messages yields, in the same order, for any subset of connections."""
    from rosbags.rosbag1 import Reader
    from tpuaf.measure.bag_decode import index_messages

    plain_bag(tmp_path, poses="odom", events=True)
    with Reader(tmp_path / "run.bag") as reader:
        for conns in (reader.connections, reader.connections[::2], reader.connections[1:2]):
            ours = [(c.id, t, bytes(raw)) for c, t, raw in index_messages(reader, list(conns))]
            theirs = [(c.id, t, bytes(raw)) for c, t, raw in reader.messages(connections=conns)]
            assert ours == theirs and len(ours) > 0


def test_analyze_takes_the_runs_robot_radius_from_its_config():
    # a dead robot's body on a vertex (recovery) is judged with the run's robot, not the map's
    from tpuaf.cli.analyze import _robot_radius

    assert _robot_radius({"robot": {"radius_m": 0.105}}) == 0.105
    assert _robot_radius({}) is None and _robot_radius({"robot": "burger"}) is None
    assert _robot_radius({"robot": {"radius_m": -1.0}}) is None
