"""Issue 22, pairings: `tpuaf analyze` checks the bag against the map (vertex ids, team size,
positions), and a resumed sweep checks the content of its maps and strategy parameters."""

from __future__ import annotations

import json

import pytest
from tpuaf.experiments.results_folder import unlock_folder
from tpuaf.experiments.sweep.execute import check_existing
from tpuaf.experiments.sweep.folders import write_run
from tpuaf.experiments.sweep.grid import SweepError, make_spec
from tpuaf.maps import load_map
from tpuaf.maps.mapfile import save_map_folder

from tests.test_bad_input import assert_one_line_error, cli
from tests.test_bag import plain_bag


@pytest.fixture(scope="module")
def grid_bag(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bag")
    plain_bag(folder, poses="odom")
    return folder / "run.bag"


@pytest.mark.parametrize("map_ref,needle", [
    ("lab", "vertex id(s) that map 'lab' does not have"),
    ("../shared/maps/patrolling_sim/cumberland", "away from every edge of map 'cumberland'"),
])
def test_analyze_of_a_bag_with_another_map_is_refused(capsys, tmp_path, grid_bag, map_ref,
                                                       needle, monkeypatch):
    """A grid bag analysed with --map lab or cumberland wrote wrong metrics, no warning."""
    from pathlib import Path

    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    if map_ref.startswith("..") and not Path(map_ref).is_dir():
        pytest.skip("the reference maps are not beside the repository")
    out = tmp_path / "analysis"
    code, _, err = cli(capsys, "analyze", str(grid_bag), "--map", map_ref, "--out", str(out))
    assert_one_line_error(code, err, "does not match map", needle, "--force")
    assert not out.exists()  # the refused analysis leaves no folder behind
    code, _, err = cli(capsys, "analyze", str(grid_bag), "--map", map_ref, "--out", str(out),
                       "--force")
    unlock_folder(out)
    assert code == 0, err
    assert "warning:" in err and needle in err
    code, _, err = cli(capsys, "analyze", str(grid_bag), "--map", "grid", "--out",
                       str(tmp_path / "right"))
    unlock_folder(tmp_path / "right")
    assert code == 0 and "warning" not in err, err


def test_analyze_with_a_smaller_team_than_the_bag_is_refused(capsys, tmp_path, grid_bag):
    code, _, err = cli(capsys, "analyze", str(grid_bag), "--map", "grid", "--robots", "1",
                       "--out", str(tmp_path / "a"))
    assert_one_line_error(code, err, "the bag holds 2 robots, the team is 1")


def fake_finished_run(root, spec, key) -> None:
    write_run(root, {"task": spec.task(key), "summary": {"duration_s": spec.duration_s},
                     "config": {}, "samples": [], "error": None})


def test_resumed_sweep_refuses_a_changed_map_folder(tmp_path):
    """Resuming a compare folder after its map folder changed mixed a 40-vertex and a
    25-vertex map in one results.csv."""
    folder = save_map_folder(load_map("grid"), tmp_path / "mymap")
    root = tmp_path / "sweep"
    spec = make_spec([str(folder)], ["cr"], [1], seeds=2, duration_s=60.0)
    fake_finished_run(root, spec, spec.keys()[0])
    assert check_existing(root, spec) == spec.keys()[1:]  # the same content: resumed
    graph = folder / "graph.yaml"
    graph.write_text(graph.read_text().replace("x: 1.425, y: 1.425", "x: 1.5, y: 1.425", 1))
    changed = make_spec([str(folder)], ["cr"], [1], seeds=2, duration_s=60.0)
    with pytest.raises(SweepError, match="changed since this run was computed"):
        check_existing(root, changed)


def test_resumed_sweep_refuses_changed_strategy_parameters(tmp_path):
    root = tmp_path / "sweep"
    spec = make_spec(["grid"], ["gbs"], [1], seeds=1, duration_s=60.0)
    fake_finished_run(root, spec, spec.keys()[0])
    summary = root / "runs" / "grid" / "gbs" / "N1" / "seed0" / "summary.json"
    data = json.loads(summary.read_text())
    data["run"]["params_hash"] = "0" * 16  # as computed with other defaults
    summary.write_text(json.dumps(data))
    with pytest.raises(SweepError, match="the parameters of gbs changed"):
        check_existing(root, spec)
