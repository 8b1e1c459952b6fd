"""Vertex geometry written once (vertex_geometry.hpp): the nearest vertex and the goal
tolerance serve the graph loop, the robot machines and the maps alike, from one default."""

from __future__ import annotations

import numpy as np
import tpuaf_core
from tpuaf.maps import load_map
from tpuaf.maps.model import MapSettings
from tpuaf.policies import REGISTRY
from tpuaf.robot.machine import RobotMachine


def test_nearest_vertex_is_numpys_argmin_first_on_ties():
    rng = np.random.default_rng(3)
    positions = np.round(rng.uniform(0, 5, size=(40, 2)))  # on a grid: many ties
    for x, y in rng.uniform(-1, 6, size=(200, 2)).round(1):
        expected = int(np.argmin(np.hypot(positions[:, 0] - x, positions[:, 1] - y)))
        assert tpuaf_core.nearest_vertex(positions, x, y) == expected
    pm = load_map("grid")
    x, y = pm.positions[7] + 0.01
    assert pm.nearest_vertex(x, y) == 7


def test_the_goal_tolerance_has_one_declared_default():
    default = tpuaf_core.DEFAULT_GOAL_TOLERANCE_M
    assert MapSettings().goal_tolerance == default
    assert tpuaf_core.EngineConfig().goal_tolerance_m == default


class _Still:
    now = 0.0
    where = (0.0, 0.0)

    def position_of(self, robot):
        return self.where


def test_a_machine_is_at_a_vertex_within_its_maps_goal_tolerance():
    pm = load_map("grid")
    driver = _Still()
    machine = RobotMachine(driver, 0, 1, pm, REGISTRY.create("gbs"), None)
    tol = float(pm.settings.goal_tolerance)
    x, y = (float(c) for c in pm.positions[3])
    driver.where = (x + tol * 0.99, y)
    assert machine.at_vertex(3)
    driver.where = (x + tol * 1.01, y)
    assert not machine.at_vertex(3)
    assert machine.nearest_vertex(x + tol * 1.01, y) == 3 == pm.nearest_vertex(x + tol, y)
