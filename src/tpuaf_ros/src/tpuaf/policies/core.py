"""Policies whose decisions are a strategy of the C++ core (`tpuaf_core.TeamStrategy`).

A strategy of the core is written once and runs in every runtime: the graph runtime's event loop
calls it for every robot (`tpuaf.runtimes.graph`), and on a live clock (the physics runtime, the
ROS agents) each robot's `CoreStrategyPolicy` calls it through a `tpuaf_core.PolicyHost`: before
each call the host gets the robot's clock, vertex and measured speed; after it, the messages the
strategy sent, the wake-up it asked for and a goal change go to the robot's context.
"""

from __future__ import annotations

import math
from typing import Any

from tpuaf.policies.base import Policy, RobotContext
from tpuaf.team.messages import Intention, Visit


def rng_stream(generator) -> Any:
    """The C++ copy of a numpy Generator's PCG64 stream (it draws what the Generator would)."""
    import tpuaf_core

    return tpuaf_core.NumpyPcg64(generator.bit_generator.state)


def to_core(message) -> Any:
    """A team message as the core's `TeamMessage`, or None for kinds the core strategies ignore."""
    import tpuaf_core

    kind = type(message)
    if kind is Visit:
        return tpuaf_core.TeamMessage.visit(int(message.robot), int(message.vertex),
                                            float(message.time), int(message.next_vertex))
    if kind is Intention:
        return tpuaf_core.TeamMessage.intention(
            int(message.robot), int(message.from_vertex), int(message.vertex),
            float(message.expected_arrival), float(message.travel_time), float(message.time))
    return None


def from_core(message) -> Visit | Intention:
    """A core `TeamMessage` as the typed team message of `tpuaf.team.messages`."""
    import tpuaf_core

    kind = message.kind
    if kind == tpuaf_core.TeamMessage.Kind.VISIT:
        return Visit(message.robot, message.vertex, message.time_s, message.next_vertex)
    if kind == tpuaf_core.TeamMessage.Kind.INTENTION:
        return Intention(message.robot, message.from_vertex, message.vertex,
                         message.expected_arrival_s, message.travel_time_s, message.time_s)
    raise ValueError(f"a core strategy sent a message of kind {kind}")


class CoreStrategyPolicy(Policy):
    """One robot's policy over a strategy of the core. Subclasses give `core_strategy`."""

    @classmethod
    def core_strategy(cls, params: dict, patrol_map, n_robots: int, streams: list) -> Any:
        """The core strategy of a team on `patrol_map` (one object holds every robot's state);
        streams: each robot's random stream (`rng_stream`)."""
        raise NotImplementedError

    def start(self, ctx: RobotContext) -> None:
        import tpuaf_core

        streams = [rng_stream(ctx.rng)] * ctx.n_robots  # only this robot's is drawn from
        self.robot = ctx.robot
        self.strategy = self.core_strategy(self.params, ctx.patrol_map, ctx.n_robots, streams)
        self.host = tpuaf_core.PolicyHost(ctx.patrol_map.graph, ctx.n_robots, ctx.robot)
        self._call(ctx, self.strategy.start)

    def _call(self, ctx: RobotContext, method, *args):
        host = self.host
        host.set_state(float(ctx.now), int(ctx.current_vertex), float(ctx.average_speed))
        result = method(host, *args)
        for message in host.take_messages():
            ctx.send(from_core(message))
        wake = host.take_wake_time()
        if not math.isnan(wake):
            ctx.wake_at(wake)
        goal = host.take_goal_change()
        change = getattr(ctx, "change_goal", None)
        if goal >= 0 and change is not None:
            change(goal)
        return result

    def decide(self, ctx: RobotContext) -> int | None:
        goal = self._call(ctx, self.strategy.decide)
        return None if goal < 0 else goal

    def on_message(self, message, ctx: RobotContext) -> None:
        core = to_core(message)
        if core is not None:
            self._call(ctx, self.strategy.on_message, core)

    def on_goal_failed(self, vertex: int, ctx: RobotContext) -> None:
        self._call(ctx, self.strategy.on_goal_failed, int(vertex))

    def retime(self, ctx: RobotContext) -> None:
        # Strategies that read the host's graph at each call (tpuaf, ...) use the new times;
        # tpuaf_plus keeps the tours it planned at the start and, with its `retime` parameter,
        # re-times them (TeamStrategy.retime: walks' arcs, lap lengths, spacing targets);
        # without it, the model's times.
        self.host.set_graph(ctx.patrol_map.graph)
        self._call(ctx, self.strategy.retime)

    def on_teammate_lost(self, robot: int, ctx: RobotContext) -> None:
        self._call(ctx, self.strategy.on_teammate_lost, int(robot))
