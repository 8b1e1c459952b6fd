"""`tpuaf graph` (maps/generate.py, cli/graph.py): a patrol graph generated from a hand-built
occupancy map with two rooms, a corridor between them and a dead-end corridor covers the free
space in line of sight, its edges are drivable, the folder it writes loads (ours and the
patrolling_sim .graph) and runs in the graph and physics runtimes; bad input is one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tpuaf.cli import main
from tpuaf.maps import load_map
from tpuaf.maps.generate import GraphOptions, coverage_of, generate_graph, work_grid
from tpuaf.maps.model import MapSettings
from tpuaf.maps.occupancy import load_occupancy
from tpuaf.maps.patrolling_sim import load_patrolling_sim

from .map_folders import write_map_server

RES = 0.05  # [m/px]
ROBOT_RADIUS = 0.105  # [m] burger
SENSING = 2.5  # [m]
# Free rectangles (x0, y0, x1, y1) [m]: room A, room B, the corridor joining them, a dead-end
# corridor going down from it.
FREE = [(0.5, 0.5, 4.5, 4.5), (7.5, 0.5, 11.5, 4.5), (4.5, 2.0, 7.5, 3.0), (5.5, 0.3, 6.3, 2.0)]
SIZE = (12.0, 5.0)  # [m]


def write_map(folder: Path, free=FREE, name: str = "house") -> Path:
    """A map_server YAML + PGM: walls black, the FREE rectangles white."""
    return write_map_server(folder, free, SIZE, name, RES)


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """The map folder `tpuaf graph` writes for the hand-built map (burger, r = 2.5 m)."""
    tmp = tmp_path_factory.mktemp("graphgen")
    yaml_path = write_map(tmp / "src")
    out = tmp / "out"
    assert main(["graph", str(yaml_path), "--robot", "burger", "--sensing-radius",
                 str(SENSING), "--out", str(out)]) == 0
    return yaml_path, out


def inside(xy, rect) -> bool:
    return rect[0] <= xy[0] <= rect[2] and rect[1] <= xy[1] <= rect[3]


def test_generated_graph_covers_rooms_corridor_and_dead_end(generated):
    yaml_path, out = generated
    pm = load_map(out)
    occ = load_occupancy(yaml_path)
    opts = GraphOptions(robot_radius_m=ROBOT_RADIUS, sensing_radius_m=SENSING)
    grid = work_grid(occ, opts)
    fraction, covered = coverage_of(grid, pm.positions, SENSING)
    assert fraction == pytest.approx(1.0)
    # the rooms and the dead end hold a vertex; the corridor one at least at its doors
    for rect in (FREE[0], FREE[1], FREE[3], (4.2, 2.0, 7.8, 3.0)):
        assert any(inside(xy, rect) for xy in pm.positions), rect
    # the dead end is a target near its far end (y < 1 m), not only seen from the corridor
    assert any(inside(xy, FREE[3]) and xy[1] < 1.0 for xy in pm.positions)
    # every vertex is drivable: clearance >= robot radius from the walls
    for x, y in pm.positions:
        assert occ.is_free(x, y)
    # fewer vertices than a lattice at the sensing radius would need
    assert 4 <= pm.num_vertices <= 16
    assert pm.settings.sensing_radius == SENSING and pm.settings.robot_radius == ROBOT_RADIUS


def test_a_far_view_is_blocked_by_walls():
    """Line of sight: a target in room A does not see room B, 7 m away and behind walls."""
    occ = load_occupancy(write_map(Path(pytest.importorskip("tempfile").mkdtemp())))
    opts = GraphOptions(robot_radius_m=ROBOT_RADIUS, sensing_radius_m=20.0)
    grid = work_grid(occ, opts)
    _, covered = coverage_of(grid, [(1.0, 1.0)], 20.0)
    row, col = grid.cell_of((9.5, 2.5))
    assert not covered[row, col]
    row, col = grid.cell_of((4.0, 4.0))
    assert covered[row, col]


def test_edges_are_drivable_and_written_with_length_and_width(generated):
    import yaml
    from tpuaf.cli.maps import edge_check

    _, out = generated
    pm = load_map(out)
    check = edge_check(pm)
    assert check["blocked"] == [] and check["edges"] == pm.graph.num_edges >= pm.num_vertices - 1
    doc = yaml.safe_load((out / "generation.yaml").read_text())
    assert len(doc["edges_m"]) == pm.graph.num_edges
    for e in doc["edges_m"]:
        assert e["length_m"] > 0 and 2 * ROBOT_RADIUS < e["free_width_m"] < 5.0
    assert doc["coverage"] == pytest.approx(1.0) and doc["vertices"] == pm.num_vertices
    assert (out / "graph.png").stat().st_size < 200_000


def test_the_patrolling_sim_files_hold_the_same_graph(generated):
    _, out = generated
    ours = load_map(out)
    ps = load_patrolling_sim(out / "house.graph")
    assert ps.num_vertices == ours.num_vertices and ps.graph.num_edges == ours.graph.num_edges
    assert np.abs(ps.positions - ours.positions).max() <= RES
    for u, v, length in ours.edges:
        assert ps.graph.edge_length(u, v) == pytest.approx(length, abs=RES)


@pytest.mark.parametrize("strategy", ["tpuaf", "tpuaf_plus"])
def test_generated_map_runs_in_the_graph_runtime(generated, strategy):
    from tpuaf.runtimes.config import RunConfig
    from tpuaf.runtimes.graph import make_run

    pm = load_map(generated[1])
    run = make_run(RunConfig(map="house", strategy=strategy, robots=2, duration_s=300), pm)
    summary = run.run()
    assert len({v for _, _, v in run.recorder.visits}) == pm.num_vertices, summary


def test_generated_map_runs_in_the_physics_runtime(generated):
    from tpuaf.runtimes.config import PhysicsConfig
    from tpuaf.runtimes.physics import PhysicsRun

    pm = load_map(generated[1])
    run = PhysicsRun(PhysicsConfig(map="house", strategy="tpuaf", robots=2, duration_s=90,
                                   robot="burger"), pm)
    run.run()
    visited = {v for _, _, v in run.recorder.visits}
    assert len(visited) >= 3  # the robots drove edges of the generated graph


def test_fixed_targets_and_min_spacing(tmp_path):
    occ = load_occupancy(write_map(tmp_path))
    fixed = ((2.0, 2.0), (10.0, 1.0))
    gen = generate_graph(occ, GraphOptions(ROBOT_RADIUS, SENSING, min_spacing_m=1.5,
                                           fixed=fixed))
    assert [tuple(p) for p in gen.positions[:2]] == list(fixed)
    assert gen.kinds[:2] == ["fixed", "fixed"]
    d = np.hypot(*(gen.positions[:, None, :] - gen.positions[None, :, :]).transpose(2, 0, 1))
    assert d[np.triu_indices(len(d), 1)].min() >= 1.5 - 1e-9
    low = generate_graph(occ, GraphOptions(ROBOT_RADIUS, SENSING, coverage=0.6))
    assert 0.6 <= low.coverage < 1.0 and len(low.positions) < len(gen.positions)


def test_a_fixed_target_in_a_wall_is_refused(tmp_path, capsys):
    yaml_path = write_map(tmp_path / "m")
    assert main(["graph", str(yaml_path), "--fixed", "6,4.5", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tpuaf graph: error: fixed target (6, 4.5) m is not where a robot")
    assert len(err.splitlines()) == 1


def bad_cases(tmp: Path) -> list[tuple[list[str], str]]:
    good = write_map(tmp / "good")
    garbled = tmp / "garbled.yaml"
    garbled.write_text("image: [unclosed\nresolution: 0.05\n")
    no_image = tmp / "noimage" / "m.yaml"
    no_image.parent.mkdir()
    no_image.write_text("image: gone.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    walls = write_map(tmp / "walls", free=[], name="walls")
    narrow = write_map(tmp / "narrow", free=[(1, 1, 1.2, 4)], name="narrow")
    bad_res = tmp / "badres" / "m.yaml"
    bad_res.parent.mkdir()
    bad_res.write_text("image: m.pgm\nresolution: fine\norigin: [0, 0, 0]\n")
    full = tmp / "full"
    full.mkdir()
    (full / "x").write_text("")
    return [
        ([str(tmp / "missing.yaml")], "missing.yaml: map YAML not found"),
        ([str(garbled)], "garbled.yaml"),
        ([str(no_image)], "image file 'gone.pgm' not found"),
        ([str(walls)], "the image has no free cell"),
        ([str(narrow)], "no free space where a robot of radius"),
        ([str(bad_res)], "'resolution' must be a finite number"),
        ([str(good), "--sensing-radius", "0"], "sensing radius must be > 0 m, got 0"),
        ([str(good), "--sensing-radius", "-2"], "sensing radius must be > 0 m"),
        ([str(good), "--coverage", "1.5"], "coverage must be a fraction in (0, 1]"),
        ([str(good), "--fixed", "1;2"], "expected X,Y in metres"),
        ([str(good), "--robot", "tank"], "unknown robot preset 'tank'"),
        ([str(good), "--name", "../x"], "--name '../x'"),
    ] + [([str(good), "--out", str(full)], "folder exists and is not empty")]


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    for argv, expected in bad_cases(tmp_path):
        out = [] if "--out" in argv else ["--out", str(tmp_path / "never")]
        try:
            code = main(["graph", *argv, *out])
        except SystemExit as stop:  # argparse's own errors
            code = stop.code
        assert code == 2, argv
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and expected in err and "Traceback" not in err, \
            (argv, err)
        assert not (tmp_path / "never").exists()


def test_settings_default_to_the_robot_model(generated):
    pm = load_map(generated[1])
    assert pm.settings.nominal_speed == pytest.approx(0.22)  # burger's limit
    assert pm.settings.goal_tolerance == MapSettings().goal_tolerance


def test_no_two_targets_closer_than_a_robots_width(tmp_path):
    """A warehouse hall with five rows of shelves (aisles 1 m wide), r = 2 m: the greedy's
    tail covers slivers at the sensing radius's rim, and took spots 0.1 m apart for them (7
    pairs under 0.5 m); targets are now at least a robot's width, 2 (radius + margin), apart,
    and every reachable free cell is still seen."""
    shelves = [(2.5, 1.5 + 1.6 * k, 13.5, 2.1 + 1.6 * k) for k in range(5)]
    hall = [(0.3, 0.3, 15.7, 9.7)]
    occ = load_occupancy(write_map_server(tmp_path / "src", hall, (16.0, 10.0), "warehouse",
                                          RES, walls=shelves))
    opts = GraphOptions(ROBOT_RADIUS, 2.0)
    gen = generate_graph(occ, opts)
    p = np.asarray(gen.positions)
    d = np.hypot(p[:, None, 0] - p[None, :, 0], p[:, None, 1] - p[None, :, 1])
    np.fill_diagonal(d, np.inf)
    assert d.min() >= 2.0 * (ROBOT_RADIUS + opts.margin_m) - 1e-9
    assert gen.coverage >= 0.995
