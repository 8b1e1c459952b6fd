"""Fuzz (hypothesis, 1,000 cases each): team messages into a live agent (AgentRuntime, ROS-free,
every strategy). Malformed robot ids, vertex ids out of the map, NaN and infinite times, wrong
estimate lengths: the agent drops or tolerates them and keeps patrolling, never raises."""

from __future__ import annotations

import math
import os

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tpuaf.maps import load_map
from tpuaf.policies import REGISTRY
from tpuaf.runtimes.agent import AgentRuntime
from tpuaf.team.messages import IdlenessEstimate, Intention, TaskBid, TaskRequest, Visit

FUZZ_EXAMPLES = int(os.environ.get("TPUAF_FUZZ_EXAMPLES", "1000"))  # fewer while iterating
FUZZ = settings(max_examples=FUZZ_EXAMPLES, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

GRID = load_map("grid")
N_ROBOTS = 3
ROBOT_IDS = st.one_of(st.integers(-3, N_ROBOTS + 2), st.sampled_from([-(2**63), 2**63, 10**12]))
VERTICES = st.one_of(st.integers(-3, GRID.num_vertices + 3),
                     st.sampled_from([-(2**31), 2**31, 10**12]))
TIMES = st.one_of(st.floats(-10.0, 200.0), st.floats(allow_nan=True, allow_infinity=True),
                  st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 0.0]))
ESTIMATE = st.lists(TIMES, min_size=0, max_size=GRID.num_vertices + 3).map(tuple)

MESSAGES = st.one_of(
    st.builds(Visit, robot=ROBOT_IDS, vertex=VERTICES, time=TIMES, next_vertex=VERTICES),
    st.builds(Intention, robot=ROBOT_IDS, from_vertex=VERTICES, vertex=VERTICES,
              expected_arrival=TIMES, travel_time=TIMES, time=TIMES),
    st.builds(IdlenessEstimate, robot=ROBOT_IDS, time=TIMES, estimate=ESTIMATE,
              next_vertex=VERTICES),
    st.builds(TaskRequest, robot=ROBOT_IDS, vertex=VERTICES, bid=TIMES, time=TIMES),
    st.builds(TaskBid, robot=ROBOT_IDS, vertex=VERTICES, bid=TIMES),
)


def live_agent(strategy: str) -> tuple[AgentRuntime, list]:
    """Robot 1 of 3, started at its start vertex and past its first decision."""
    sent: list = []
    agent = AgentRuntime(GRID, REGISTRY.create(strategy), 1, N_ROBOTS, 0, sent.append,
                         lambda kind, vertex, from_vertex, t: None)
    x, y = GRID.positions[12]
    agent.on_pose(0.0, float(x), float(y), 0.0)
    agent.tick(0.0, None)
    agent.tick(0.1, None)
    return agent, sent


@FUZZ
@given(strategy=st.sampled_from(REGISTRY.names()),
       messages=st.lists(MESSAGES, min_size=1, max_size=8))
def test_fuzz_team_messages_into_a_live_agent(strategy, messages):
    agent, _ = live_agent(strategy)
    t = 0.1
    x, y = GRID.positions[12]
    for k, message in enumerate(messages):
        agent.on_message(message)
        t += 0.5
        agent.on_pose(t, float(x), float(y), 0.0)
        v, w = agent.tick(t, np.zeros((0, 2)) if k % 2 else None)
        assert math.isfinite(v) and math.isfinite(w)
    goal = agent.goal
    assert goal is None or 0 <= goal < GRID.num_vertices
