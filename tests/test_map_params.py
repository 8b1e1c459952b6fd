"""Map parameters a user can set (issue 34 part 3): precedence default < imported default / map
file < `--map-param` (CLI) or `map_params` (node parameter, launch arg); imported defaults scale
with the map and the robot; `tpuaf maps` prints each value and where it came from; the overrides
reach the runs (config.yaml, metrics) and the sweep's tasks. The RViz view framed on the map
(part 4) is checked here without ROS."""

from __future__ import annotations

import json
import shlex
import subprocess
from pathlib import Path

import pytest
import yaml
from tpuaf.maps import MapError, load_map
from tpuaf.maps.mapfile import save_map_folder
from tpuaf.maps.params import (
    CLI,
    IMPORTED,
    MAP_FILE,
    effective_params,
    imported_defaults,
    parse_map_params,
)
from tpuaf.params import AgentParams, MonitorParams, parse

REPO = Path(__file__).resolve().parents[1]
TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
PS_DIR = REPO.parent / "shared" / "maps" / "patrolling_sim"
needs_shared = pytest.mark.skipif(not (PS_DIR / "cumberland").is_dir(),
                                  reason=f"no patrolling_sim maps in {PS_DIR}")


def tpuaf(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([TPUAF, *args], capture_output=True, text=True, timeout=timeout)


def test_map_file_values_then_cli_overrides():
    pm = load_map("lab")
    p = effective_params(pm)
    assert p["sensing_radius"] == {"value": 0.5, "unit": "m", "source": MAP_FILE}
    pm = load_map("lab", params={"sensing_radius": 0.8, "growth_coefficients": "1, 0.3"},
                  params_origin=CLI)
    p = effective_params(pm)
    assert p["sensing_radius"]["value"] == 0.8 and p["sensing_radius"]["source"] == CLI
    assert p["growth_coefficients"]["value"] == [1.0, 0.3]
    assert pm.uncertainty_model().growth_coefficients == [1.0, 0.3]
    assert p["interference_distance"] == {"value": 0.3, "unit": "m", "source": MAP_FILE}


def test_a_key_missing_from_the_map_file_is_the_default(tmp_path):
    pm = load_map("lab")
    save_map_folder(pm, tmp_path / "m", occupancy_file=True)
    text = (tmp_path / "m" / "map.yaml").read_text()
    text = "\n".join(line for line in text.splitlines() if "interference_distance" not in line)
    (tmp_path / "m" / "map.yaml").write_text(text + "\n")
    p = effective_params(load_map(str(tmp_path / "m")))
    assert p["interference_distance"]["source"] == "built-in default"
    assert p["interference_distance"]["value"] == 2.0  # MapSettings'
    assert p["sensing_radius"]["source"] == MAP_FILE


@needs_shared
def test_imported_defaults_are_specs_and_scale_down_on_a_small_map():
    big = load_map(str(PS_DIR / "cumberland"))
    assert big.settings.sensing_radius == 5.0  # the paper's r
    assert big.settings.interference_distance == 2.0  # SPEC's d_if
    assert big.settings.nominal_speed == 1.0
    source = effective_params(big)["sensing_radius"]["source"]
    assert source == f"{IMPORTED}: the paper's r"  # 51.6 m across: 5 m is a tenth of it
    small = load_map(str(PS_DIR / "1r5"))  # 10 m across: r scaled to a quarter of that
    assert small.settings.sensing_radius == pytest.approx(2.5, abs=0.01)
    assert "x the graph's 10.0 m span" in effective_params(small)["sensing_radius"]["source"]
    over = load_map(str(PS_DIR / "1r5"), params={"sensing_radius": 4.0}, params_origin=CLI)
    assert effective_params(over)["sensing_radius"] == {"value": 4.0, "unit": "m",
                                                        "source": CLI}


def test_imported_defaults_of_a_single_spot_have_no_hint():
    d = imported_defaults([[1.0, 1.0]])
    assert d["sensing_radius"] == (5.0, "imported default: the paper's r")


def test_imported_sensing_radius_scales_with_the_span_up_to_the_papers():
    assert imported_defaults([[0, 0], [8, 3]])["sensing_radius"][0] == pytest.approx(2.0)
    assert imported_defaults([[0, 0], [20, 3]])["sensing_radius"][0] == 5.0  # exactly 5 m
    assert imported_defaults([[0, 0], [60, 3]])["sensing_radius"][0] == 5.0


@pytest.mark.parametrize("items, wanted", [
    (["radius=2"], "unknown map parameter 'radius'"),
    (["sensing_radius"], "expected KEY=VALUE"),
    (["sensing_radius=-1"], "sensing_radius must be > 0"),
    (["nominal_speed=fast"], "nominal_speed must be a finite number"),
    (["interference_distance=nan"], "interference_distance must be a finite number"),
    (["growth_coefficients="], "expected KEY=VALUE"),
    (["growth_coefficients=1,x"], "growth_coefficients must be a finite number"),
])
def test_bad_overrides_are_named(items, wanted):
    with pytest.raises(MapError, match=wanted):
        parse_map_params(items)


def test_exponents_and_the_last_value_win():
    assert parse_map_params(["sensing_radius=5e-1", "sensing_radius=0.7"]) == \
        {"sensing_radius": 0.7}


def test_node_parameter_map_params_reaches_the_map():
    agent = parse(AgentParams, {"map": "lab", "robots": 1, "robot_index": 0,
                                "map_params": {"sensing_radius": 2.0}}, "/a")
    monitor = parse(MonitorParams, {"map": "lab", "robots": 1,
                                    "map_params": {"interference_distance": 0.5}}, "/m")
    pm = load_map(agent.map, params=agent.map_params, params_origin="~map_params")
    assert pm.settings.sensing_radius == 2.0
    pm = load_map(monitor.map, params=monitor.map_params, params_origin="~map_params")
    assert effective_params(pm)["interference_distance"]["source"] == "~map_params"
    with pytest.raises(MapError, match="~map_params: unknown map parameter 'speed'"):
        load_map("lab", params={"speed": 1.0}, params_origin="~map_params")


def test_tpuaf_maps_prints_each_value_and_its_source():
    proc = tpuaf("maps", "lab", "--map-param", "sensing_radius=0.8")
    assert proc.returncode == 0, proc.stderr
    lines = {line.split()[0]: line for line in proc.stdout.splitlines()
             if line.startswith("  ") and "(" in line}
    assert "0.8 m" in lines["sensing_radius"] and "(--map-param)" in lines["sensing_radius"]
    assert "0.3 m" in lines["interference_distance"]
    assert "(map file)" in lines["interference_distance"]
    js = json.loads(tpuaf("maps", "lab", "--json", "--map-param",
                          "interference_distance=0.4").stdout)
    assert js[0]["parameters"]["interference_distance"] == {"value": 0.4, "unit": "m",
                                                             "source": "--map-param"}


def test_a_bad_map_param_is_one_line_and_exit_2():
    for command in (["maps", "lab"], ["run", "--map", "lab", "--duration", "10"]):
        proc = tpuaf(*command, "--map-param", "bogus=1")
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
        assert "unknown map parameter 'bogus'" in proc.stderr


def test_run_overrides_reach_the_metrics_and_config_yaml(tmp_path):
    summaries = {}
    for radius in (0.2, 1.5):  # [m] d_if and r alike
        out = tmp_path / f"r{radius}"
        proc = tpuaf("run", "--map", "lab", "--robots", "3", "--duration", "300", "--quiet",
                     "--no-plots", "--out", str(out), "--map-param",
                     f"interference_distance={radius}", "--map-param", f"sensing_radius={radius}")
        assert proc.returncode == 0, proc.stderr
        config = yaml.safe_load((out / "config.yaml").read_text())
        assert config["map_params"] == {"interference_distance": radius,
                                        "sensing_radius": radius}
        assert config["map_settings"]["sensing_radius"] == radius
        assert config["map_setting_sources"]["interference_distance"] == "--map-param"
        summaries[radius] = json.loads((out / "summary.json").read_text())
        assert summaries[radius]["interference_distance_m"] == radius
    # a wider sensing disc keeps the targets' uncertainty X lower (Eq. 1-3)
    assert summaries[1.5]["uncertainty_mean"] < summaries[0.2]["uncertainty_mean"]


def test_sweep_tasks_carry_the_overrides():
    from tpuaf.experiments.sweep.grid import make_spec
    from tpuaf.experiments.sweep.worker import run_config

    plain = make_spec(["lab"], ["gbs"], [2], 1, duration_s=60)
    spec = make_spec(["lab"], ["gbs"], [2], 1, duration_s=60,
                     map_params={"sensing_radius": 0.9})
    task = spec.task(spec.keys()[0])
    assert task["map_params"] == {"sensing_radius": 0.9}
    assert run_config(task).map_params == {"sensing_radius": 0.9}
    assert task["map_hash"] != plain.task(plain.keys()[0])["map_hash"]  # no mixed resumes


def test_rviz_view_is_framed_on_the_map():
    from tpuaf.measure.rviz_view import (
        BARS_HEIGHT_PX,
        DOCK_WIDTH_PX,
        framed_config,
        map_extent,
        top_down_view,
    )

    template = (REPO / "src/tpuaf_ros/rviz/tpuaf.rviz").read_text()
    pm = load_map("grid")
    extent = map_extent(pm)
    assert extent == pytest.approx((0.0, 0.0, 25.8, 25.8))
    text = framed_config(template, extent, pm.name)
    view = yaml.safe_load(text)["Visualization Manager"]["Views"]["Current"]
    assert (view["X"], view["Y"]) == pytest.approx((12.9, 12.9))
    width, height = 1100 - DOCK_WIDTH_PX, 720 - BARS_HEIGHT_PX
    assert 25.8 * view["Scale"] <= min(width, height)  # all of it shows
    assert 25.8 * view["Scale"] >= 0.8 * min(width, height)  # and fills the view
    lab = top_down_view(map_extent(load_map("lab")), 1100, 720)
    assert lab["Scale"] > 8 * view["Scale"]  # a small room is zoomed in
    with pytest.raises(ValueError, match="TopDownOrtho"):
        framed_config("Panels: []\n", extent, "grid")


def test_fleet_passes_the_overrides_to_the_launch_file(tmp_path):
    """`tpuaf fleet --map-param` (CLI) becomes fleet.launch's map_params (launch): one value
    for every node; fleet_config.yaml (merged into config.yaml) records them."""
    out = tmp_path / "fleet"
    proc = tpuaf("fleet", "--map", "lab", "--robots", "2", "--out", str(out), "--prepare-only",
                 "--map-param", "sensing_radius=0.9", "--map-param",
                 "growth_coefficients=1,0.3")
    assert proc.returncode == 0, proc.stderr
    arg = next(a for a in shlex.split(proc.stdout.splitlines()[-1]) if "map_params:=" in a)
    given = yaml.safe_load(arg.split(":=", 1)[1])
    assert given == {"sensing_radius": 0.9, "growth_coefficients": [1.0, 0.3]}
    config = yaml.safe_load((out / "fleet_config.yaml").read_text())
    assert config["map_params"] == given
    assert config["map_settings"]["sensing_radius"] == 0.9
    assert config["map_setting_sources"]["sensing_radius"] == CLI
    assert config["map_setting_sources"]["interference_distance"] == MAP_FILE
