"""RViz with the shipped config against a running fleet, under Xvfb: the screenshot is not blank
and shows the markers' colours (robots, graph, vertex scale). On a map other than lab (a
patrolling_sim map, else the built-in grid) the view is framed on the map: the whole graph is in
view, not cut by the window's edges, and fills much of it.

Fleet: own roscore, tpuaf_stage in wall-clock rehearsal mode, 2 Burgers on `lab` with one
robot.launch each (tf localisation), then `roslaunch tpuaf_ros rviz.launch` (patrol_markers +
RViz with rviz/tpuaf.rviz) on a private X display. The screenshot is taken with Pillow's
ImageGrab from the X display. TPUAF_RVIZ_SCREENSHOT=<path> also saves it there (the docs'
picture, docs/images/rviz.png, is made so).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import time

import numpy as np
import pytest

from .conftest import REPO, ros_master, stop_process

pytestmark = [pytest.mark.ros, pytest.mark.slow]

TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
ROBOTS = 2
WAIT_S = float(os.environ.get("TPUAF_RVIZ_WAIT", "30"))  # [s of wall time] of patrol
SCALE_S = 40.0  # [s] idleness drawn red: fresh visits green, the others yellow to red


def start_xvfb(size="1100x720x24") -> tuple[subprocess.Popen, str]:
    """Xvfb on a free display (it picks and reports the number: -displayfd)."""
    r, w = os.pipe()
    proc = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-screen", "0", size, "-nolisten",
                             "tcp"], pass_fds=(w,), stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    os.close(w)
    with os.fdopen(r) as f:
        number = f.readline().strip()
    if not number:
        stop_process(proc)
        pytest.fail("Xvfb did not start")
    return proc, f":{number}"


def near(image: np.ndarray, rgb, tol=40) -> int:
    """Pixels within `tol` of colour `rgb` (0..255) in every channel."""
    return int((np.abs(image.astype(int) - np.array(rgb)).max(axis=2) <= tol).sum())


@pytest.mark.skipif(shutil.which("rviz") is None or shutil.which("Xvfb") is None,
                    reason="rviz or Xvfb not installed (launch_scripts/setup.sh installs them)")
def test_rviz_shows_the_patrol_markers(tmp_path):
    from PIL import ImageGrab
    from tpuaf.measure.markers import EDGE_COLOUR, ROBOT_COLOURS

    prep = subprocess.run([TPUAF, "fleet", "--map", "lab", "--robots", str(ROBOTS),
                           "--duration", "60", "--out", str(tmp_path / "prep"),
                           "--prepare-only"], capture_output=True, text=True, timeout=60)
    assert prep.returncode == 0, prep.stderr
    world = tmp_path / "prep" / "world.resolved.yaml"
    xvfb, display = start_xvfb()
    try:
        with ros_master(tmp_path / "ros") as ros:
            ros.run_python("import rospy; rospy.set_param('/use_sim_time', False)", timeout=30)
            ros.start(["rosrun", "tpuaf_stage", "tpuaf_stage", f"_world:={world}",
                       "_wall_clock:=true", "_publish_map_tf:=true"], name="stage")
            for i in range(ROBOTS):
                ros.start(["roslaunch", "--wait", "tpuaf_ros", "robot.launch", f"index:={i}",
                           f"robots:={ROBOTS}", "map:=lab"], name=f"agent{i}")
            rviz = ros.start(["roslaunch", "--wait", "tpuaf_ros", "rviz.launch", "map:=lab",
                              f"robots:={ROBOTS}", f"idleness_scale:={SCALE_S}"], name="rviz",
                             DISPLAY=display,
                             LIBGL_ALWAYS_SOFTWARE="1")
            time.sleep(WAIT_S)
            assert rviz.poll() is None, ros.output("rviz")[-3000:]
            markers = ros.run_python(
                "import rospy\nfrom visualization_msgs.msg import MarkerArray\n"
                "rospy.init_node('m', anonymous=True)\n"
                "m = rospy.wait_for_message('/patrol_markers/markers', MarkerArray, 20)\n"
                "print(sorted({x.ns for x in m.markers}))\n", timeout=60)
            shot = ImageGrab.grab(xdisplay=display)
    finally:
        stop_process(xvfb)
    assert markers.returncode == 0, markers.stderr
    for ns in ("graph_edges", "vertices_idleness", "footprints", "intentions"):
        assert ns in markers.stdout, markers.stdout
    target = os.environ.get("TPUAF_RVIZ_SCREENSHOT")
    if target:
        shot.save(target)
    shot.save(tmp_path / "rviz.png")
    image = np.asarray(shot.convert("RGB"))
    assert image.std() > 20, "blank screenshot"
    robot_px = [near(image, [round(255 * c) for c in ROBOT_COLOURS[i][:3]]) for i in range(ROBOTS)]
    assert all(n > 30 for n in robot_px), robot_px
    assert near(image, [round(255 * c) for c in EDGE_COLOUR[:3]], tol=25) > 200  # the graph
    # vertices on the green -> yellow -> red scale: fresh visits green, older ones not
    r, g, b = (image[..., k].astype(int) for k in range(3))
    scale = ((r > 150) | (g > 150)) & (b < 80)
    greenish = int((scale & (g > r + 60)).sum())
    warm = int((scale & (r > g - 60)).sum())  # yellow, orange, red
    assert greenish > 50 and warm > 50, (greenish, warm)


PS_MAP = REPO.parent / "shared" / "maps" / "patrolling_sim" / "cumberland"
EDGE_MARGIN_PX = 4  # the graph's pixels stay this far inside the 3-D view
# The 3-D view in the 1100 x 720 window of rviz/tpuaf.rviz (left of it the Displays dock, above
# it the menu and tool bar, below it the status bar: their icons are coloured too) [px].
VIEW_LEFT_PX, VIEW_TOP_PX, VIEW_RIGHT_PX, VIEW_BOTTOM_PX = 364, 62, 1084, 690


@pytest.mark.skipif(shutil.which("rviz") is None or shutil.which("Xvfb") is None,
                    reason="rviz or Xvfb not installed (launch_scripts/setup.sh installs them)")
def test_rviz_frames_a_map_other_than_lab(tmp_path):
    from PIL import ImageGrab
    from tpuaf.maps import load_map

    map_ref = str(PS_MAP) if PS_MAP.is_dir() else "grid"
    pm = load_map(map_ref)
    xvfb, display = start_xvfb()
    try:
        with ros_master(tmp_path / "ros") as ros:
            ros.run_python("import rospy; rospy.set_param('/use_sim_time', False)", timeout=30)
            rviz = ros.start(["roslaunch", "--wait", "tpuaf_ros", "rviz.launch",
                              f"map:={map_ref}", "robots:=1", "pose_source:=ground_truth"],
                             name="rviz", DISPLAY=display, LIBGL_ALWAYS_SOFTWARE="1")
            time.sleep(min(WAIT_S, 20.0))
            assert rviz.poll() is None, ros.output("rviz")[-3000:]
            shot = ImageGrab.grab(xdisplay=display)
    finally:
        stop_process(xvfb)
    shot.save(tmp_path / "rviz_framed.png")
    image = np.asarray(shot.convert("RGB"))
    # the vertices: discs on the idleness colour scale, the only saturated colour in view (the
    # map, the edges and the background are grey)
    rgb = image[VIEW_TOP_PX:VIEW_BOTTOM_PX, VIEW_LEFT_PX:VIEW_RIGHT_PX].astype(int)
    vertex = (rgb.max(axis=2) - rgb.min(axis=2)) > 100
    rows, cols = np.nonzero(vertex)
    assert len(rows) > 200, "no vertices in view"
    top, bottom, left, right = rows.min(), rows.max(), cols.min(), cols.max()
    height, width = vertex.shape
    # the whole graph: no vertex at the view's border (a cut view runs off it)
    assert top >= EDGE_MARGIN_PX and left >= EDGE_MARGIN_PX, (top, left)
    assert bottom < height - EDGE_MARGIN_PX and right < width - EDGE_MARGIN_PX, (bottom, right)
    # framed, not a dot: the graph spans much of the view, with the map's aspect ratio
    span = pm.positions.max(axis=0) - pm.positions.min(axis=0)
    assert max(right - left, bottom - top) > 0.4 * min(width, height), (right - left, bottom - top)
    aspect = (right - left) / max(bottom - top, 1)
    assert aspect == pytest.approx(span[0] / span[1], rel=0.15), (aspect, span)
