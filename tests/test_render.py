"""`tpuaf render` and the per-run summary.png (issue 13, item 4).

A short batch run (grid, 3 robots, 60 s) writes its results folder; its summary.png is a valid
PNG; `tpuaf render` writes a valid GIF with the asked number of frames, by count or by step,
coloured by idleness or by X; the trajectories rebuilt from visits.csv pass through every
visited vertex at its visit time and never move faster than the nominal speed."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image
from tpuaf.cli import main
from tpuaf.experiments.animation import Trajectories, frame_times
from tpuaf.experiments.plots import _read_csv
from tpuaf.maps import load_map

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("render") / "run"
    assert main(["run", "--map", "grid", "--robots", "3", "--duration", "60", "--quiet",
                 "--out", str(out)]) == 0
    return out


def test_every_results_folder_has_a_summary_png(run_folder):
    data = (run_folder / "summary.png").read_bytes()
    assert data[:8] == PNG
    with Image.open(run_folder / "summary.png") as im:
        im.verify()
    with Image.open(run_folder / "summary.png") as im:
        assert im.format == "PNG" and im.size[0] > 300 and im.size[1] > 150


def test_render_writes_a_gif_with_the_asked_frame_count(run_folder, capsys):
    out = run_folder / "anim.gif"
    assert main(["render", str(run_folder), "--frames", "12", "--out", str(out)]) == 0
    assert "12 frames" in capsys.readouterr().out
    assert out.read_bytes()[:6] in (b"GIF87a", b"GIF89a")
    with Image.open(out) as im:
        assert im.format == "GIF"
        assert im.n_frames == 12
        assert im.info.get("duration") == 100  # 10 fps
        frames = []
        for k in (0, 11):
            im.seek(k)
            frames.append(np.asarray(im.convert("RGB")))
    assert not np.array_equal(frames[0], frames[1])  # the robots moved, the clock changed


def test_render_by_step_and_by_uncertainty(run_folder):
    out = run_folder / "x.gif"
    assert main(["render", str(run_folder), "--step", "7.5", "--color", "uncertainty",
                 "--fps", "5", "--out", str(out)]) == 0
    with Image.open(out) as im:
        assert im.n_frames == len(frame_times(0.0, 60.0, step_s=7.5)) == 9
        assert im.info.get("duration") == 200


def test_default_animation_path_and_bad_input(run_folder, tmp_path, capsys):
    assert main(["render", str(run_folder), "--frames", "3"]) == 0
    with Image.open(run_folder / "animation.gif") as im:
        assert im.n_frames == 3
    assert main(["render", str(tmp_path / "nowhere")]) == 2
    assert "no such results folder" in capsys.readouterr().err
    assert main(["render", str(run_folder), "--out", str(tmp_path / "a.avi")]) == 2
    err = capsys.readouterr().err
    assert ".gif or an .mp4" in err and "Traceback" not in err
    (tmp_path / "empty").mkdir()
    assert main(["render", str(tmp_path / "empty")]) == 2
    assert "no config.yaml" in capsys.readouterr().err


def test_rebuilt_trajectories_meet_every_visit_at_nominal_speed(run_folder):
    pm = load_map("grid")
    traj = Trajectories(run_folder, pm, 3, float(pm.settings.nominal_speed))
    assert traj.source == "visits.csv"
    xy = np.asarray(pm.positions)
    for r in _read_csv(run_folder / "visits.csv"):
        p = traj.at(float(r["time_s"]))[int(r["robot"])]
        assert np.allclose(p, xy[int(r["vertex_index"])], atol=1e-6), r
    t = np.arange(0.0, 60.0, 0.25)
    pos = np.array([traj.at(x) for x in t])  # (T, robots, 2)
    speed = np.linalg.norm(np.diff(pos, axis=0), axis=2) / 0.25
    assert speed.max() <= pm.settings.nominal_speed * (1 + 1e-6)
    assert speed.max() > 0.5 * pm.settings.nominal_speed  # they do move


def test_positions_csv_is_preferred_when_recorded(run_folder, tmp_path):
    import shutil

    folder = tmp_path / "with_positions"
    shutil.copytree(run_folder, folder)
    (folder / "positions.csv").write_text(
        "time_s,robot,x,y\n0,0,1.0,2.0\n10,0,3.0,2.0\n0,1,0,0\n0,2,5,5\n")
    traj = Trajectories(folder, load_map("grid"), 3, 1.0)
    assert traj.source == "positions.csv"
    assert np.allclose(traj.at(5.0)[0], [2.0, 2.0])
    assert not math.isnan(traj.at(5.0)[2][0])
