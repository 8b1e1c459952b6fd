"""Maps (SPEC section 7): patrolling_sim imports, built-in maps, our format, errors, statistics."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from tpuaf.maps import (
    MapError,
    builtin_map_names,
    corridors_from_graph,
    load_map,
    load_occupancy,
    map_summary,
    start_vertices,
)
from tpuaf.maps.builtin import make_grid, make_lab
from tpuaf.maps.mapfile import save_map_folder
from tpuaf.paths import builtin_maps_dir

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
PS_DIR = SHARED / "maps" / "patrolling_sim"
PS_MAPS = sorted(p for p in PS_DIR.iterdir() if p.is_dir() and any(p.glob("*.graph"))) \
    if PS_DIR.is_dir() else []
needs_shared = pytest.mark.skipif(not PS_MAPS, reason=f"no patrolling_sim maps in {PS_DIR}")


def raw_graph(path: Path) -> dict:
    """An independent reading of a .graph file: header and directed adjacency."""
    tok = path.read_text().split()
    n, w, h = int(tok[0]), int(tok[1]), int(tok[2])
    res, ox, oy = float(tok[3]), float(tok[4]), float(tok[5])
    pos = 6
    verts, directed = {}, []
    for _ in range(n):
        vid, x, y, k = int(tok[pos]), float(tok[pos + 1]), float(tok[pos + 2]), int(tok[pos + 3])
        pos += 4
        verts[vid] = (x, y)
        for _ in range(k):
            directed.append((vid, int(tok[pos]), float(tok[pos + 2])))
            pos += 3
    return {"n": n, "w": w, "h": h, "res": res, "off": (ox, oy), "verts": verts,
            "directed": directed}


# ---------------------------------------------------------------------------------------------
# patrolling_sim imports


@needs_shared
def test_sample_maps_are_discovered():
    names = {p.name for p in PS_MAPS}
    assert {"cumberland", "grid"} <= names
    assert len(PS_MAPS) >= 6


@needs_shared
@pytest.mark.parametrize("folder", PS_MAPS, ids=lambda p: p.name)
def test_patrolling_sim_map_imports(folder):
    pm = load_map(folder)
    raw = raw_graph(folder / f"{folder.name}.graph")
    assert pm.num_vertices == raw["n"] == len(raw["verts"])
    pairs = {frozenset((u, v)) for u, v, _ in raw["directed"]}
    assert pm.graph.num_edges == len(pairs)
    # symmetric: every listed edge is listed the other way too
    listed = {(u, v) for u, v, _ in raw["directed"]}
    assert all((v, u) in listed for u, v in listed)
    # metric coordinates, on free cells of the occupancy grid, inside the image
    occ = pm.occupancy
    assert occ.width == raw["w"] and occ.height == raw["h"]
    for i, vid in enumerate(pm.vertex_ids):
        xp, yp = raw["verts"][vid]
        assert pm.positions[i] == pytest.approx(
            (xp * raw["res"] + raw["off"][0], yp * raw["res"] + raw["off"][1]))
        assert occ.is_free(*pm.positions[i]), f"vertex {vid} of {folder.name} not on free space"
    # lengths = shortest listed cost * resolution
    for u, v, length in pm.graph.edges:
        a, b = pm.vertex_ids[u], pm.vertex_ids[v]
        costs = [c for x, y, c in raw["directed"] if {x, y} == {a, b}]
        assert length == pytest.approx(min(costs) * raw["res"])


@needs_shared
def test_cumberland_and_grid_match_the_paper():
    cumberland = load_map(PS_DIR / "cumberland")
    assert (cumberland.num_vertices, cumberland.graph.num_edges) == (40, 44)
    s = map_summary(cumberland)
    assert (s["size_x_m"], s["size_y_m"]) == pytest.approx((51.6, 37.425))
    # Paper Table 1: Fiedler value 0.0109 (cumberland), 0.1313 (grid).
    assert round(s["fiedler_value"], 4) == 0.0109
    grid = load_map(PS_DIR / "grid" / "grid.graph")
    assert (grid.num_vertices, grid.graph.num_edges) == (25, 40)
    assert round(map_summary(grid)["fiedler_value"], 4) == 0.1313


@needs_shared
def test_initial_poses_and_variants():
    grid = load_map(PS_DIR / "grid")
    assert grid.settings.initial_poses[1] == [(1.425, 24.375)]
    assert sorted(grid.settings.initial_poses) == [1, 2, 4, 5, 6, 8, 10, 12]
    assert "4_a" in grid.settings.initial_pose_variants
    starts = start_vertices(grid, 4)
    assert len(set(starts)) == 4
    assert grid.vertex_ids[starts[0]] == 0  # (1.425, 24.375) is vertex 0
    # grid_4_a crowds four poses near one corner: still four distinct vertices
    grid.settings.initial_poses[4] = grid.settings.initial_pose_variants["4_a"]
    assert len(set(start_vertices(grid, 4))) == 4


@needs_shared
def test_parallel_edges_are_merged_and_reported():
    example = load_map(PS_DIR / "example")
    assert any("parallel edge" in note for note in example.notes)


# ---------------------------------------------------------------------------------------------
# built-in maps


def test_builtin_grid():
    pm = load_map("grid")
    assert (pm.num_vertices, pm.graph.num_edges) == (25, 40)
    coords = sorted({round(float(x), 6) for x in pm.positions.ravel()})
    assert coords == pytest.approx([1.425 + 5.7 * k for k in range(5)])
    assert pm.settings.nominal_speed == 1.0 and pm.settings.sensing_radius == 5.0
    s = map_summary(pm)
    assert (s["size_x_m"], s["size_y_m"]) == pytest.approx((25.8, 25.8))
    assert round(s["fiedler_value"], 4) == 0.1313
    assert s["mean_edge_length_m"] == pytest.approx(5.7)


def test_builtin_lab():
    pm = load_map("lab")
    assert (pm.num_vertices, pm.graph.num_edges) == (15, 16)
    r = pm.settings.robot_radius
    assert r == 0.105
    assert pm.positions[:, 0].min() - r > 0 and pm.positions[:, 0].max() + r < 3.0
    assert pm.positions[:, 1].min() - r > 0 and pm.positions[:, 1].max() + r < 2.6
    s = map_summary(pm)
    assert (s["size_x_m"], s["size_y_m"]) == pytest.approx((3.0, 2.6))
    assert pm.settings.sensing_radius / pm.settings.nominal_speed == pytest.approx(5.0)
    for n in range(1, 5):
        starts = start_vertices(pm, n)
        assert len(set(starts)) == n


@pytest.mark.parametrize("name", ["grid", "lab"])
def test_builtin_corridors_fit_the_robot(name):
    pm = load_map(name)
    occ = pm.occupancy
    r = pm.settings.robot_radius
    ring = [(r * np.cos(a), r * np.sin(a)) for a in np.linspace(0, 2 * np.pi, 16, endpoint=False)]
    for u, v, _ in pm.graph.edges:
        for f in np.linspace(0, 1, 11):
            x, y = pm.positions[u] * (1 - f) + pm.positions[v] * f
            assert all(occ.is_free(x + dx, y + dy) for dx, dy in ring)


@pytest.mark.parametrize("name,make", [("grid", make_grid), ("lab", make_lab)])
def test_committed_builtin_files_match_generator(name, make, tmp_path):
    committed = load_map(name)
    fresh = make()
    assert committed.vertex_ids == fresh.vertex_ids
    assert np.allclose(committed.positions, fresh.positions)
    assert [e[:2] for e in committed.graph.edges] == [e[:2] for e in fresh.graph.edges]
    assert committed.settings == fresh.settings
    regenerated = save_map_folder(fresh, tmp_path / name, occupancy_file=True)
    assert np.array_equal(load_occupancy(regenerated / "occupancy.yaml").occupied,
                          committed.occupancy.occupied)


def test_unknown_map_name_lists_builtins():
    with pytest.raises(MapError) as err:
        load_map("no_such_map")
    msg = str(err.value)
    assert all(n in msg for n in builtin_map_names()) and "path" in msg
    assert builtin_map_names() == ["grid", "lab"]


def test_start_vertices_spread_and_wrap():
    pm = make_grid()
    starts = start_vertices(pm, 2)
    assert starts[0] == 0 and pm.graph.distance(0, starts[1]) == pytest.approx(4 * 5.7 * 2)
    assert start_vertices(pm, 2) == starts  # deterministic
    many = start_vertices(pm, 27)
    assert len(set(many[:25])) == 25 and many[25:] == many[:2]
    with pytest.raises(MapError):
        start_vertices(pm, 0)


# ---------------------------------------------------------------------------------------------
# occupancy


def test_load_occupancy_p2_orientation_negate_thresholds(tmp_path):
    # 3 x 2 image; top row: white, grey (unknown), black; bottom row: black, white, white.
    (tmp_path / "m.pgm").write_text("P2\n# c\n3 2\n255\n255 128 0\n0 255 255\n")
    (tmp_path / "m.yaml").write_text(
        "image: m.pgm\nresolution: 0.5\norigin: [1.0, 2.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    occ = load_occupancy(tmp_path / "m.yaml")
    # row 0 is the bottom of the map
    assert occ.occupied.tolist() == [[True, False, False], [False, True, True]]
    assert occ.is_free(1.1, 2.1) is False and occ.is_free(1.1, 2.6) is True
    assert occ.is_free(1.6, 2.6) is False  # grey = unknown counts as occupied
    assert occ.is_free(0.0, 0.0) is False  # outside
    (tmp_path / "n.yaml").write_text(
        "image: m.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nnegate: 1\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    assert load_occupancy(tmp_path / "n.yaml").occupied.tolist() == \
        [[False, True, True], [True, True, False]]


def test_corridors_from_graph():
    pm = make_lab()
    occ = corridors_from_graph(pm, corridor_width_m=0.4, resolution_m=0.02)
    assert occ.extent == pytest.approx((0.0, 0.0, 3.0, 2.6))
    assert all(occ.is_free(x, y) for x, y in pm.positions)
    assert occ.is_free(1.2, 0.3) and occ.is_free(0.3, 0.8)  # on edges
    assert not occ.is_free(1.2, 0.8)  # inside a desk block
    assert not occ.is_free(0.9, 0.3 + 0.25)  # beyond half a corridor width from any edge


# ---------------------------------------------------------------------------------------------
# malformed inputs

GOOD_GRAPH = """3
40
20
0.5
0
0

0
5
5
1
1
E
20

1
25
5
2
0
W
20
2
E
10

2
35
5
1
1
W
10
"""

PS_YAML = ("image: tiny.pgm\nresolution: 0.5\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
           "occupied_thresh: 0.65\nfree_thresh: 0.196\n")


def ps_folder(tmp_path: Path, graph: str = GOOD_GRAPH, yaml_text: str = PS_YAML,
              image: bool = True) -> Path:
    folder = tmp_path / "tiny"
    folder.mkdir(exist_ok=True)
    (folder / "tiny.graph").write_text(graph)
    (folder / "tiny.yaml").write_text(yaml_text)
    if image:
        pixels = np.full((20, 40), 254, dtype=np.uint8)
        (folder / "tiny.pgm").write_bytes(b"P5\n40 20\n255\n" + pixels.tobytes())
    return folder


def error_of(path) -> str:
    with pytest.raises(MapError) as err:
        load_map(path)
    return str(err.value)


def test_good_tiny_graph_imports(tmp_path):
    pm = load_map(ps_folder(tmp_path))
    assert pm.num_vertices == 3 and pm.graph.num_edges == 2
    assert pm.graph.edge_length(0, 1) == pytest.approx(10.0)
    assert pm.positions[2] == pytest.approx((17.5, 2.5))


def line_of_token(text: str, token_index: int) -> int:
    count = 0
    for lineno, line in enumerate(text.splitlines(), start=1):
        count += len(line.split())
        if count > token_index:
            return lineno
    raise AssertionError


@pytest.mark.parametrize(
    "graph,expect",
    [
        ("\n".join(GOOD_GRAPH.split("\n")[:30]), r"tiny.graph:\d+ \(end of file\).*truncated"),
        (GOOD_GRAPH.replace("0.5\n", "zero.5\n", 1), r"tiny.graph:4 .*number.*zero\.5"),
        (GOOD_GRAPH.replace("2\nE\n10", "7\nE\n10"), r"tiny.graph:23 .*unknown neighbour 7"),
        (GOOD_GRAPH.replace("\n1\n1\nE\n20\n", "\n1\n2\nE\n20\n", 1),
         r"tiny.graph:\d+ .*asymmetric edge"),
        (GOOD_GRAPH.replace("3\n40", "2\n40", 1), r"tiny.graph:\d+ .*vertex count mismatch"),
        (GOOD_GRAPH.replace("3\n40", "4\n40", 1), r"tiny.graph:\d+ .*truncated"),
        (GOOD_GRAPH.replace("E\n20", "Q\n20", 1), r"tiny.graph:13 .*compass direction"),
    ],
    ids=["truncated", "bad-number", "unknown-neighbour", "asymmetric", "count-mismatch-extra",
         "count-mismatch-missing", "bad-direction"],
)
def test_malformed_graph_names_file_and_line(tmp_path, graph, expect):
    msg = error_of(ps_folder(tmp_path, graph=graph))
    assert re.search(expect, msg), msg


def test_disconnected_graph(tmp_path):
    graph = """3\n40\n20\n0.5\n0\n0\n0 5 5 1 1 E 20\n1 25 5 1 0 W 20\n2 35 5 0\n"""
    msg = error_of(ps_folder(tmp_path, graph=graph))
    assert "tiny" in msg and "disconnected" in msg


def test_bad_map_server_yaml_and_missing_image(tmp_path):
    msg = error_of(ps_folder(tmp_path, yaml_text="image: [unclosed\n"))
    assert re.search(r"tiny.yaml:\d+: invalid YAML", msg), msg
    msg = error_of(ps_folder(tmp_path, yaml_text=PS_YAML + "colour: red\n"))
    assert "tiny.yaml" in msg and "unknown key" in msg and "colour" in msg
    shutil.rmtree(tmp_path / "tiny")
    msg = error_of(ps_folder(tmp_path, yaml_text=PS_YAML.replace("tiny.pgm", "other.pgm"),
                             image=False))
    assert "tiny.yaml" in msg and "other.pgm" in msg and "not found" in msg


def test_truncated_pgm(tmp_path):
    folder = ps_folder(tmp_path)
    (folder / "tiny.pgm").write_bytes(b"P5\n40 20\n255\n" + b"\xfe" * 100)
    msg = error_of(folder)
    assert "tiny.pgm" in msg and "truncated" in msg


def our_folder(tmp_path: Path) -> Path:
    return save_map_folder(make_lab(), tmp_path / "mylab")


def test_our_format_round_trip(tmp_path):
    folder = our_folder(tmp_path)
    pm = load_map(folder)
    assert (pm.num_vertices, pm.graph.num_edges) == (15, 16)
    assert pm.settings == make_lab().settings
    assert pm.occupancy is not None  # generated corridors
    # per-vertex overrides
    text = (folder / "graph.yaml").read_text().replace(
        "{id: 7, x: 1.5, y: 1.3}", "{id: 7, x: 1.5, y: 1.3, importance: 0.05, initial_uncertainty: 3}")
    (folder / "graph.yaml").write_text(text)
    pm = load_map(folder)
    i = pm.index_of(7)
    assert pm.importance[i] == 0.05 and pm.initial_uncertainty[i] == 3.0
    assert pm.importance[0] == 0.01


@pytest.mark.parametrize(
    "file,old,new,expect",
    [
        ("map.yaml", "  robot_radius: 0.105", "  robot_radius: 0.105\n  colour: red",
         r"map.yaml:\d+: unknown key\(s\) colour in settings"),
        ("map.yaml", "name: lab", "name: lab\nsize: 3", r"map.yaml:\d+: unknown key\(s\) size"),
        ("map.yaml", "graph: graph.yaml", "graph: [graph.yaml", r"map.yaml:\d+: invalid YAML"),
        ("map.yaml", "nominal_speed: 0.1", "nominal_speed: fast", r"map.yaml:\d+: 'nominal_speed'"),
        ("map.yaml", "graph: graph.yaml", "graph: nograph.yaml", r"map.yaml:\d+: graph file"),
        ("graph.yaml", "{id: 3, x: 2.1, y: 0.3}", "{id: 3, x: 2.1, y: 0.3, z: 1}",
         r"graph.yaml:7: unknown key\(s\) z in vertex"),
        ("graph.yaml", "  - [13, 14]", "  - [13, 99]", r"graph.yaml:\d+: edge 13-99 names unknown"),
        ("graph.yaml", "{id: 3, x: 2.1,", "{id: 3, x: two,", r"graph.yaml:7: 'x' must be"),
        ("graph.yaml", "vertices:\n", "vertices:\n  - {id: 99, x: 1.0, y: 1.0}\n", r"disconnected"),
    ],
    ids=["unknown-setting", "unknown-key", "bad-yaml", "bad-number", "missing-graph",
         "unknown-vertex-key", "unknown-vertex", "bad-coordinate", "disconnected"],
)
def test_our_format_errors(tmp_path, file, old, new, expect):
    folder = our_folder(tmp_path)
    path = folder / file
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    msg = error_of(folder)
    assert re.search(expect, msg), msg
    assert "mylab" in msg


def test_our_format_missing_occupancy_image(tmp_path):
    folder = save_map_folder(make_lab(), tmp_path / "mylab", occupancy_file=True)
    (folder / "occupancy.pgm").unlink()
    msg = error_of(folder)
    assert "occupancy.yaml" in msg and "not found" in msg


def test_maps_cli(capsys):
    from tpuaf.cli import main

    assert main(["maps", "grid", "lab"]) == 0
    out = capsys.readouterr().out
    assert "0.1313" in out and "25.8 x 25.8" in out and "3.0 x 2.6" in out
    assert main(["maps", "nowhere"]) == 2
    assert "unknown map" in capsys.readouterr().err


# ---------------------------------------------------------------------------------------------
# geometry checks (issue 12): where vertices lie, edge lengths, start vertices

GRID_DIR = builtin_maps_dir() / "grid"


def grid_copy(tmp_path: Path, old: str | None = None, new: str | None = None,
              file: str = "graph.yaml") -> Path:
    """The built-in grid folder (with its occupancy image), one text replaced in `file`."""
    folder = tmp_path / "mygrid"
    shutil.copytree(GRID_DIR, folder)
    if old is not None:
        path = folder / file
        text = path.read_text()
        assert old in text
        path.write_text(text.replace(old, new, 1))
    return folder


def test_vertex_far_away_is_refused(tmp_path):
    msg = error_of(grid_copy(tmp_path, "{id: 3, x: 1.425, y: 7.125}", "{id: 3, x: 1.0e+12, y: 7.125}"))
    assert "vertex 3" in msg and "1e+12" in msg and "mygrid" in msg


def test_vertex_far_away_without_image_is_refused_before_a_grid_is_built(tmp_path):
    folder = grid_copy(tmp_path, "occupancy: occupancy.yaml\n", "", file="map.yaml")
    text = (folder / "map.yaml").read_text().replace("bounds: [0.0, 0.0, 25.8, 25.8]  # [m]\n", "")
    (folder / "map.yaml").write_text(text)
    graph = folder / "graph.yaml"
    graph.write_text(graph.read_text().replace("{id: 4, x: 1.425, y: 1.425}",
                                               "{id: 4, x: 1.425, y: -1.0e+12}"))
    msg = error_of(folder)
    assert "vertex 4" in msg and "beyond" in msg


def test_vertex_on_an_occupied_cell_is_refused_or_warned(tmp_path):
    # (4.275, 4.275) m lies between the corridors of the grid: a wall
    folder = grid_copy(tmp_path, "{id: 8, x: 7.125, y: 7.125}", "{id: 8, x: 4.275, y: 4.275}")
    msg = error_of(folder)
    assert "occupied" in msg and "8 (4.275, 4.275)" in msg and "--allow-occupied-vertices" in msg
    pm = load_map(folder, allow_occupied_vertices=True)
    assert any("occupied" in w for w in pm.warnings)


def test_vertex_outside_the_image_is_refused(tmp_path):
    folder = grid_copy(tmp_path, "{id: 24, x: 24.225, y: 1.425}", "{id: 24, x: 24.225, y: -3.0}")
    msg = error_of(folder)
    assert "outside the occupancy image" in msg and "24 (24.225, -3)" in msg


def test_edge_shorter_than_the_straight_line_warns(tmp_path):
    pm = load_map(grid_copy(tmp_path, "  - [0, 1]\n", "  - [0, 1, 2.0]\n"))
    assert any("shorter than the straight line" in w and "0-1 (2 m < 5.7 m)" in w
               for w in pm.warnings), pm.warnings


def test_graph_larger_than_its_image_warns(tmp_path):
    graph = GOOD_GRAPH.replace("3\n40\n20\n", "3\n80\n20\n", 1)  # header: 80 px, image: 40
    pm = load_map(ps_folder(tmp_path, graph=graph))
    assert any("larger than its image" in w for w in pm.warnings), pm.warnings


def test_duplicate_start_vertices_are_refused(tmp_path):
    folder = grid_copy(tmp_path, "  default_initial_uncertainty: 1.0  # X0_j\n",
                       "  default_initial_uncertainty: 1.0  # X0_j\n"
                       "  initial_vertices: {3: [0, 5, 0]}\n", file="map.yaml")
    msg = error_of(folder)
    assert re.search(r"map\.yaml:\d+: initial_vertices\[3\] starts several robots at vertex 0",
                     msg), msg


def test_duplicate_start_poses_are_refused(tmp_path):
    folder = ps_folder(tmp_path)
    (folder / "initial_poses.txt").write_text("[InitialPoses]\ntiny_2 = [2.5, 2.5, 2.5, 2.5]\n")
    msg = error_of(folder)
    assert "start robots 0 and 1 at the same pose" in msg


def test_geometry_cli_flag_and_one_line(tmp_path, capsys):
    from tpuaf.cli import main

    folder = grid_copy(tmp_path, "{id: 8, x: 7.125, y: 7.125}", "{id: 8, x: 4.275, y: 4.275}")
    assert main(["maps", str(folder)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "occupied" in err
    assert main(["maps", "--allow-occupied-vertices", str(folder)]) == 0
    assert "warning" in capsys.readouterr().err
    assert main(["run", "--map", str(folder), "--duration", "5", "--quiet",
                 "--allow-occupied-vertices"]) == 0
    assert "warning" in capsys.readouterr().err


@pytest.mark.parametrize("file, old, new, line, kind", [
    ("map.yaml", "name: lab\n", "name: lab\n? [1, 2]\n: 3\n", 2, "list"),
    ("map.yaml", "name: lab\n", "name: lab\n{a: 1}: 2\n", 2, "mapping"),
    ("graph.yaml", "{id: 3, x: 2.1, y: 0.3}", "{id: 3, x: 2.1, y: 0.3, [z]: 1}", 7, "list"),
], ids=["list-key", "mapping-key", "list-key-in-vertex"])
def test_a_non_scalar_mapping_key_is_one_map_error_line(tmp_path, capsys, file, old, new, line,
                                                        kind):
    """Fuzzer regression: a list as a mapping key was `TypeError: unhashable type: '_LineList'`."""
    from tpuaf.cli import main

    folder = our_folder(tmp_path)
    path = folder / file
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    msg = error_of(folder)
    assert msg == f"{path}:{line}: a mapping key must be a scalar, got a {kind}", msg
    assert main(["maps", str(folder)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "must be a scalar" in err and "Traceback" not in err


def test_a_list_as_edge_vertex_is_an_unknown_vertex(tmp_path):
    """Fuzzer regression: `[[], 14]` as an edge was `TypeError: unhashable type: '_LineList'`."""
    folder = our_folder(tmp_path)
    path = folder / "graph.yaml"
    text = path.read_text()
    assert "  - [13, 14]" in text
    path.write_text(text.replace("  - [13, 14]", "  - [[], 14]", 1))
    assert re.search(r"graph\.yaml:\d+: edge \[\]-14 names unknown vertex \[\]$", error_of(folder))


@pytest.mark.parametrize("argv, path", [
    (["maps", "./nope"], "./nope"),
    (["run", "--map", "/tmp/nope-xyz", "--duration", "5", "--quiet"], "/tmp/nope-xyz"),
], ids=["maps-relative", "run-absolute"])
def test_a_missing_map_path_is_no_such_map_folder(capsys, argv, path):
    """A map argument that is a path (has '/', starts with '.' or '~') and does not exist is
    "no such map folder PATH", not "unknown map"; a bare name stays an unknown map."""
    from tpuaf.cli import main

    assert not Path(path).exists()
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].endswith(f"no such map folder {path}"), err
    assert "unknown map" not in err
    with pytest.raises(MapError, match="^unknown map 'nope'"):
        load_map("nope")


# ---------------------------------------------------------------- map files as ROS writes them


@pytest.mark.parametrize("yaml_text", [
    "image: tiny.pgm\nresolution: 5e-1\norigin: [0.0, -0e0, 0]\nnegate: 0\n"
    "occupied_thresh: 6.5e-1\nfree_thresh: 1.96e-1\n",
    "image: tiny.pgm\nresolution: \"0.5\"\norigin: [\"0.0\", '0', 0.0]\nnegate: \"0\"\n"
    "occupied_thresh: \"0.65\"\nfree_thresh: '0.196'\n",
], ids=["exponents", "quoted"])
def test_map_yaml_numbers_in_every_form_ros_writes(tmp_path, yaml_text):
    pm = load_map(ps_folder(tmp_path, yaml_text=yaml_text))
    grid = pm.occupancy_grid()
    assert grid.resolution == 0.5 and grid.origin == (0.0, 0.0)
    assert not grid.occupied.any()


@pytest.mark.parametrize("key, value, expected", [
    ("resolution", "fine", "'resolution' must be a finite number (e.g. 0.05, 5e-2 or "
                           "\"0.05\"), got 'fine'"),
    ("resolution", "\"5e-2x\"", "got '5e-2x'"),
    ("negate", "\"yes please\"", "'negate' must be 0 or 1 (or true / false), got 'yes please'"),
])
def test_a_bad_map_yaml_value_names_the_value_and_what_is_expected(tmp_path, key, value,
                                                                   expected):
    text = "".join(f"{key}: {value}\n" if line.startswith(f"{key}:") else line + "\n"
                   for line in PS_YAML.splitlines())
    msg = error_of(ps_folder(tmp_path, yaml_text=text))
    assert expected in msg and "tiny.yaml" in msg, msg


def test_our_map_yaml_reads_exponents_and_quoted_numbers(tmp_path):
    folder = our_folder(tmp_path)
    path = folder / "map.yaml"
    text = path.read_text()
    text = re.sub(r"sensing_radius: \S+", "sensing_radius: 5e-1", text)
    text = re.sub(r"nominal_speed: \S+", 'nominal_speed: "0.1"', text)
    path.write_text(text)
    (folder / "graph.yaml").write_text((folder / "graph.yaml").read_text().replace(
        "{id: 3, x: 2.1, y: 0.3}", "{id: 3, x: 2.1e0, y: \"0.3\"}"))
    pm = load_map(folder)
    assert pm.settings.sensing_radius == 0.5 and pm.settings.nominal_speed == 0.1
    assert tuple(pm.positions[3]) == (2.1, 0.3)


def test_coincident_vertices_are_refused(tmp_path, capsys):
    """Two vertices on the same spot (here 3 and 8 of the lab, 1e-4 m apart) are an error of
    load_map, `tpuaf maps` and `tpuaf run`, naming both."""
    from tpuaf.cli import main

    folder = our_folder(tmp_path)
    path = folder / "graph.yaml"
    path.write_text(path.read_text().replace("{id: 8, x: 2.1, y: 1.3}",
                                             "{id: 8, x: 2.1, y: 0.3001}"))
    msg = error_of(folder)
    assert "vertices on the same spot" in msg and "3 and 8 at (2.1, 0.3)" in msg, msg
    assert main(["maps", str(folder)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "same spot" in err
    assert main(["run", "--map", str(folder), "--duration", "5", "--quiet"]) == 2
    assert "same spot" in capsys.readouterr().err


def test_coincident_pairs_finds_near_and_exact_pairs_only():
    from tpuaf.maps.geometry import coincident_pairs

    pos = np.array([[0, 0], [1, 0], [0, 0], [1, 5e-4], [1, 1], [0.0005, 0.0009]], dtype=float)
    assert coincident_pairs(pos) == [(0, 2), (1, 3)]
    grid = np.array([[x, y] for x in range(30) for y in range(30)], dtype=float)
    assert coincident_pairs(grid) == []
