"""The C++ world (tpuaf_core.World): hand-checkable lasers, kinematics, contacts, determinism."""

import math

import numpy as np
import pytest
import tpuaf_core as tc

RES = 0.1  # [m per cell] of the tiny worlds below


def empty(h=40, w=60):
    return np.zeros((h, w), dtype=bool)


def beam(angle=0.0, range_max=10.0, **kw):
    """A one-beam laser pointing at `angle` [rad] in the robot frame."""
    return tc.LaserSpec(beams=1, angle_min_rad=angle, angle_increment_rad=0.1, range_min_m=0.0,
                        range_max_m=range_max, **kw)


def one_ray(world_grid, pose, angle=0.0, radius=0.1, **kw):
    w = tc.World(world_grid, RES, (0.0, 0.0))
    w.add_robot(pose, tc.RobotSpec(radius_m=radius), beam(angle, **kw))
    return float(w.scan(0)[0])


def wall_at_x3():
    g = empty()
    g[:, 30] = True  # cells x in [3.0, 3.1) m
    return g


# --- laser -------------------------------------------------------------------------------------


def test_wall_at_known_distance():
    assert one_ray(wall_at_x3(), (1.0, 1.05, 0.0)) == pytest.approx(2.0, abs=1e-6)
    # The same wall seen with the robot turned: beam at -pi/2 in a robot facing +pi/2.
    assert one_ray(wall_at_x3(), (1.0, 1.05, math.pi / 2), angle=-math.pi / 2) == pytest.approx(
        2.0, abs=1e-6)


def test_map_edge_is_a_wall():
    # Behind the robot the map ends at x = 0.
    assert one_ray(wall_at_x3(), (1.0, 1.05, 0.0), angle=math.pi) == pytest.approx(1.0, abs=1e-6)
    # Above: the map is 40 rows = 4.0 m high.
    assert one_ray(empty(), (1.0, 1.05, 0.0), angle=math.pi / 2) == pytest.approx(2.95, abs=1e-6)


def test_corner():
    g = empty()
    g[20, :21] = True  # a horizontal wall: y in [2.0, 2.1), x < 2.1
    g[:21, 20] = True  # a vertical wall: x in [2.0, 2.1), y < 2.1
    # Straight into the corner point (2, 2) at 45 degrees from (1, 1).
    assert one_ray(g, (1.0, 1.0, math.pi / 4)) == pytest.approx(math.sqrt(2.0), abs=1e-6)
    # Towards (1.5, 2.0): the horizontal wall, at sqrt(0.5^2 + 1^2).
    a = math.atan2(1.0, 0.5)
    assert one_ray(g, (1.0, 1.0, a)) == pytest.approx(math.hypot(0.5, 1.0), abs=1e-6)
    # Towards (2.0, 1.25): the vertical wall.
    a = math.atan2(0.25, 1.0)
    assert one_ray(g, (1.0, 1.0, a)) == pytest.approx(math.hypot(1.0, 0.25), abs=1e-6)


def test_out_of_range_beams():
    pose = (1.0, 1.05, 0.0)
    assert one_ray(wall_at_x3(), pose, range_max=1.5) == math.inf
    assert one_ray(wall_at_x3(), pose, range_max=1.5, no_return_range=0.0) == 0.0
    assert one_ray(wall_at_x3(), pose, range_max=1.5, no_return_range=1.5) == 1.5
    # Exactly at range_max is still a return.
    assert one_ray(wall_at_x3(), pose, range_max=2.0) == pytest.approx(2.0, abs=1e-6)


def test_range_min_clamps_close_returns():
    # Map edge 0.2 m behind the robot; range_min 0.3 m.
    w = tc.World(empty(), RES)
    w.add_robot((0.2, 1.0, 0.0), tc.RobotSpec(radius_m=0.1),
                tc.LaserSpec(beams=1, angle_min_rad=math.pi, range_min_m=0.3, range_max_m=5.0))
    assert w.scan(0)[0] == pytest.approx(0.3)


def test_laser_offset():
    assert one_ray(wall_at_x3(), (1.0, 1.05, 0.0), x_offset_m=0.1) == pytest.approx(1.9, abs=1e-6)
    assert one_ray(wall_at_x3(), (1.0, 1.05, 0.0), angle=-math.pi / 2,
                   yaw_offset_rad=math.pi / 2) == pytest.approx(2.0, abs=1e-6)


def test_another_robot_in_view_and_blocking_the_wall():
    w = tc.World(wall_at_x3(), RES)
    w.add_robot((0.5, 1.05, 0.0), tc.RobotSpec(radius_m=0.1), beam())
    w.add_robot((2.0, 1.05, math.pi), tc.RobotSpec(radius_m=0.2), beam())
    scans = w.scan_all()
    assert scans.shape == (2, 1) and scans.dtype == np.float32
    assert scans[0, 0] == pytest.approx(2.0 - 0.2 - 0.5, abs=1e-6)  # the disc of robot 1
    assert scans[1, 0] == pytest.approx(1.5 - 0.1, abs=1e-6)  # robot 1 looking back at robot 0
    # A beam passing beside the disc at a known offset: tangent geometry.
    w2 = tc.World(empty(), RES)
    w2.add_robot((0.5, 1.0, 0.0), tc.RobotSpec(radius_m=0.1), beam(math.atan2(0.1, 1.5)))
    w2.add_robot((2.0, 1.2, 0.0), tc.RobotSpec(radius_m=0.2), beam())
    d = np.array([1.5, 0.1]) / math.hypot(1.5, 0.1)
    c = np.array([1.5, 0.2])
    proj = d @ c
    expected = proj - math.sqrt(proj**2 - (c @ c - 0.04))
    assert w2.scan(0)[0] == pytest.approx(expected, abs=1e-6)


def test_full_scan_matches_single_rays_and_is_fast_path_consistent():
    rng = np.random.default_rng(3)
    g = rng.random((60, 80)) < 0.08
    g[25:35, 35:45] = False
    w = tc.World(g, 0.05, (-1.0, 2.0))
    laser = tc.LaserSpec(beams=360, angle_min_rad=-math.pi, range_max_m=3.0)
    w.add_robot((-1.0 + 2.0, 2.0 + 1.5, 0.3), tc.RobotSpec(radius_m=0.1), laser)
    ranges = w.scan(0)
    for k in range(0, 360, 7):
        a = 0.3 - math.pi + k * math.pi / 180
        expected = w.cast_ray(1.0, 3.5, a, 3.0)
        assert ranges[k] == pytest.approx(min(expected, math.inf), abs=1e-5)
        # Brute force along the ray in 0.1 mm steps: no occupied point before the reported hit.
        t = np.arange(0.0, min(float(ranges[k]), 3.0) - 1e-3, 1e-4)
        xs, ys = 1.0 + t * math.cos(a), 3.5 + t * math.sin(a)
        cols = np.floor((xs + 1.0) / 0.05).astype(int)
        rows = np.floor((ys - 2.0) / 0.05).astype(int)
        assert not g[rows, cols].any()


def test_noise_is_seeded_and_clamped():
    def scans(seed):
        w = tc.World(wall_at_x3(), RES, seed=seed)
        w.add_robot((1.0, 1.05, 0.0), tc.RobotSpec(),
                    tc.LaserSpec(beams=90, angle_min_rad=-0.7, angle_increment_rad=0.01,
                                 range_max_m=2.05, noise_std_m=0.02))
        return np.concatenate([w.scan(0) for _ in range(5)])

    a, b, c = scans(1), scans(1), scans(2)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    finite = a[np.isfinite(a)]
    assert finite.size > 0 and finite.max() <= 2.05 and finite.min() >= 0.12
    assert 0.005 < np.std(a[:90][np.isfinite(a[:90])] - scans_noiseless()) < 0.05


def scans_noiseless():
    w = tc.World(wall_at_x3(), RES)
    w.add_robot((1.0, 1.05, 0.0), tc.RobotSpec(),
                tc.LaserSpec(beams=90, angle_min_rad=-0.7, angle_increment_rad=0.01,
                             range_max_m=2.05))
    s = w.scan(0)
    return s[np.isfinite(s)]


# --- kinematics ---------------------------------------------------------------------------------


def free_robot(**kw):
    spec = dict(radius_m=0.1, max_linear_speed=1.0, max_angular_speed=2.0,
                max_linear_accel=math.inf, max_angular_accel=math.inf)
    spec.update(kw)
    w = tc.World(empty(200, 200), RES)
    w.add_robot((10.0, 10.0, 0.0), tc.RobotSpec(**spec), beam())
    return w


def test_constant_twist_gives_the_analytic_arc():
    w = free_robot()
    v, om = 0.4, 0.5
    w.set_command(0, v, om)
    for _ in range(300):
        w.step(0.01)
    t = 3.0
    x, y, th = w.poses()[0]
    assert x == pytest.approx(10.0 + v / om * math.sin(om * t), abs=1e-9)
    assert y == pytest.approx(10.0 + v / om * (1 - math.cos(om * t)), abs=1e-9)
    assert th == pytest.approx(om * t, abs=1e-9)
    assert w.velocities()[0] == pytest.approx([v, om])
    # Noise-free odometry is the same motion, from zero.
    assert w.odom_poses()[0] == pytest.approx([x - 10.0, y - 10.0, th], abs=1e-9)
    assert w.time == pytest.approx(3.0)


def test_straight_line_and_integrate_arc():
    assert tc.integrate_arc(1.0, 2.0, 0.0, 0.5, 0.0, 2.0) == pytest.approx((2.0, 2.0, 0.0))
    x, y, th = tc.integrate_arc(0.0, 0.0, 0.0, 1.0, math.pi, 1.0)  # half circle of radius 1/pi
    assert (x, y, th) == pytest.approx((0.0, 2 / math.pi, math.pi), abs=1e-12)


def test_speed_and_acceleration_limits():
    w = free_robot(max_linear_accel=1.0, max_angular_accel=2.0)
    w.set_command(0, 5.0, -9.0)
    w.step(0.1)
    assert w.velocities()[0] == pytest.approx([0.1, -0.2])
    for _ in range(30):
        w.step(0.1)
    assert w.velocities()[0] == pytest.approx([1.0, -2.0])  # clamped to the maxima


# --- contacts -----------------------------------------------------------------------------------


def thin_wall_world(res=0.05):
    g = np.zeros((80, 160), dtype=bool)
    g[:, 60] = True  # one cell: x in [3.0, 3.05) m
    return tc.World(g, res)


@pytest.mark.parametrize("dt", [0.05, 0.1, 0.5])
def test_no_tunnelling_through_a_thin_wall_at_max_speed(dt):
    w = thin_wall_world()
    r = 0.165
    w.add_robot((1.0, 2.0, 0.0), tc.RobotSpec(radius_m=r, max_linear_speed=1.0,
                                              max_linear_accel=math.inf), beam())
    w.set_command(0, 1.0, 0.0)
    stalled_seen = False
    for _ in range(int(5.0 / dt)):
        w.step(dt)
        assert w.poses()[0, 0] <= 3.0 - r + 1e-9
        stalled_seen |= bool(w.stalled()[0])
    x = w.poses()[0, 0]
    assert x == pytest.approx(3.0 - r, abs=1e-4)  # stopped at the wall, not before
    assert stalled_seen and w.stalled()[0]
    assert w.velocities()[0] == pytest.approx([0.0, 0.0])
    assert w.contact_counts()[0] > 0
    # Backing away is allowed and clears the flag.
    w.set_command(0, -1.0, 0.0)
    w.step(dt)
    assert not w.stalled()[0] and w.poses()[0, 0] < x


def test_no_tunnelling_through_another_robot():
    w = tc.World(empty(40, 100), RES)
    spec = tc.RobotSpec(radius_m=0.165, max_linear_speed=1.0, max_linear_accel=math.inf)
    w.add_robot((2.0, 2.0, 0.0), spec, beam())
    w.add_robot((3.0, 2.0, math.pi), spec, beam())
    w.set_commands(np.array([[1.0, 0.0], [1.0, 0.0]]))
    w.step(0.5)  # each would move 0.5 m: they would swap sides without contacts
    xa, xb = w.poses()[:, 0]
    assert xa < xb
    assert xb - xa == pytest.approx(0.33, abs=1e-4)
    assert w.stalled().any()
    for _ in range(4):
        w.step(0.5)
        assert w.poses()[1, 0] - w.poses()[0, 0] >= 0.33 - 1e-9


def test_turning_in_contact_is_free():
    w = thin_wall_world()
    w.add_robot((3.0 - 0.2 - 0.01, 2.0, 0.0), tc.RobotSpec(radius_m=0.2), beam())
    w.set_command(0, 0.0, 1.0)
    w.step(0.5)
    assert not w.stalled()[0]
    assert w.poses()[0, 2] == pytest.approx(0.5)  # turned by 1 rad/s for 0.5 s


def test_disc_contact_queries():
    w = thin_wall_world()
    assert w.disc_hits_wall(2.9, 2.0, 0.11)
    assert not w.disc_hits_wall(2.8, 2.0, 0.19)
    assert w.disc_hits_wall(0.05, 2.0, 0.1)  # the map edge
    w.add_robot((1.0, 1.0, 0.0), tc.RobotSpec(radius_m=0.2), beam())
    assert w.disc_hits_robot(1.35, 1.0, 0.2) == 0
    assert w.disc_hits_robot(1.45, 1.0, 0.2) == -1
    assert w.clearance(1.0, 2.0) <= 1.0 + 1e-9


# --- odometry, reset, determinism, errors -------------------------------------------------------


def driven_world(seed, noise=0.05):
    g = np.zeros((100, 100), dtype=bool)
    g[40:60, 70] = True
    w = tc.World(g, RES, seed=seed)
    spec = tc.RobotSpec(odom_linear_noise=noise, odom_angular_noise=noise)
    w.add_robot((2.0, 5.0, 0.0), spec, tc.LaserSpec(noise_std_m=0.01))
    w.add_robot((2.0, 3.0, 0.5), spec, tc.LaserSpec(noise_std_m=0.01))
    out = []
    for k in range(200):
        w.set_commands(np.array([[0.2, 0.3 * math.sin(k / 20)], [0.22, -0.1]]))
        w.step(0.05)
        if k % 10 == 0:
            out.append(w.scan_all().copy())
    return w, np.array(out)


def test_deterministic_for_a_seed():
    w1, s1 = driven_world(7)
    w2, s2 = driven_world(7)
    w3, s3 = driven_world(8)
    assert np.array_equal(s1, s2) and np.array_equal(w1.odom_poses(), w2.odom_poses())
    assert np.array_equal(w1.poses(), w2.poses())
    assert not np.array_equal(w1.odom_poses(), w3.odom_poses())
    assert np.array_equal(w1.poses(), w3.poses())  # noise is on the sensors only


def test_odometry_noise_drifts_and_reset_restores():
    w, _ = driven_world(1, noise=0.1)
    truth, odom = w.poses(), w.odom_poses()
    assert np.abs(odom[0, :2] - (truth[0, :2] - [2.0, 5.0])).max() > 1e-3
    w.reset()
    assert w.poses() == pytest.approx(np.array([[2.0, 5.0, 0.0], [2.0, 3.0, 0.5]]))
    assert not w.odom_poses().any() and not w.velocities().any()


def test_set_pose_and_errors():
    w = thin_wall_world()
    w.add_robot((1.0, 1.0, 0.0))
    w.set_pose(0, 2.0, 2.0, 1.0)
    assert w.poses()[0] == pytest.approx([2.0, 2.0, 1.0])
    with pytest.raises(ValueError, match="overlap a wall"):
        w.set_pose(0, 3.0, 2.0, 0.0)
    assert w.poses()[0] == pytest.approx([2.0, 2.0, 1.0])
    with pytest.raises(ValueError, match="overlaps a wall"):
        w.add_robot((3.02, 1.0, 0.0))
    with pytest.raises(ValueError, match="overlaps robot 0"):
        w.add_robot((2.1, 2.0, 0.0))
    with pytest.raises(IndexError):
        w.scan(5)
    with pytest.raises(ValueError, match="resolution"):
        tc.World(empty(), 0.0)
    with pytest.raises(ValueError, match="range_max"):
        w.add_robot((1.0, 3.0, 0.0), tc.RobotSpec(), tc.LaserSpec(range_min_m=2.0, range_max_m=1.0))
    with pytest.raises(ValueError, match="radius"):
        w.add_robot((1.0, 3.0, 0.0), tc.RobotSpec(radius_m=-1.0))
    with pytest.raises(ValueError, match="dt"):
        w.step(0.0)
    with pytest.raises(ValueError, match="rows"):
        w.set_commands(np.zeros((3, 2)))


def test_scan_all_needs_equal_beams():
    w = tc.World(empty(), RES)
    w.add_robot((1.0, 1.0, 0.0), tc.RobotSpec(), tc.LaserSpec(beams=10))
    w.add_robot((3.0, 1.0, 0.0), tc.RobotSpec(), tc.LaserSpec(beams=20))
    with pytest.raises(ValueError, match="same beam count"):
        w.scan_all()
    assert w.scan(1).shape == (20,)


# --- world files and their resolved form (tpuaf_stage, no ROS) ------------------------------------

from pathlib import Path  # noqa: E402

from tpuaf_stage.resolve import RESOLVED_KEY, write_resolved  # noqa: E402

from tpuaf_stage import WorldError, load_world  # noqa: E402

TEMPLATE = Path(__file__).resolve().parents[1] / "src/tpuaf_stage/config/world_template.yaml"


def write_map(folder: Path) -> Path:
    occ = np.zeros((100, 100), dtype=bool)
    occ[:2, :] = occ[-2:, :] = occ[:, :2] = occ[:, -2:] = True
    (folder / "m.pgm").write_bytes(b"P5\n100 100\n255\n" + np.where(occ[::-1], 0, 254)
                                   .astype(np.uint8).tobytes())
    (folder / "m.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [-1.0, -2.0, 0.0]\n")
    return folder / "m.yaml"


def test_template_parses_with_documented_defaults():
    cfg = load_world(TEMPLATE)
    assert cfg.robot.radius == 0.105 and cfg.robot.max_linear_speed == 0.22
    assert cfg.laser.beams == 360 and cfg.laser.range_max == 3.5 and cfg.laser.rate == 5.0
    assert cfg.laser.angle_increment == pytest.approx(math.pi / 180)
    assert cfg.laser.no_return_range == math.inf
    assert cfg.build().num_robots == 2
    # Every key of the template is a real key (the parser refuses unknown ones).
    assert "patrolling_sim" in TEMPLATE.read_text()


def test_world_file_presets_and_overrides(tmp_path):
    write_map(tmp_path)
    (tmp_path / "w.yaml").write_text(
        "map: m.yaml\nrobot: {preset: patrolling_sim, max_angular_speed: 2.0}\n"
        "laser: {beams: 181, fov: 3.14159, no_return: zero, noise_std: 0.0}\n"
        "robots: [[1.0, 1.0], [3.0, 3.0, 1.5]]\n")
    cfg = load_world(tmp_path / "w.yaml")
    assert cfg.robot.radius == 0.165 and cfg.robot.max_linear_speed == 1.0
    assert cfg.robot.max_angular_speed == 2.0
    assert cfg.laser.first_angle == pytest.approx(-3.14159 / 2)
    assert cfg.laser.angle_increment == pytest.approx(3.14159 / 180)
    assert cfg.origin == (-1.0, -2.0) and cfg.poses[0] == (1.0, 1.0, 0.0)
    w = cfg.build()
    assert w.robot_spec(0).radius_m == 0.165
    scan = w.scan(0)
    assert scan.shape == (181,) and (scan == 0.0).any()  # beams beyond 3.5 m read zero


@pytest.mark.parametrize("text, message", [
    ("map: m.yaml\nrobots: [[1, 1]]\nspeed: 3\n", "w.yaml:1: unknown key(s) speed"),
    ("map: m.yaml\nrobots: [[1, 1]]\nlaser:\n  beams: 10\n  fvo: 1\n", "w.yaml:4: unknown key(s) fvo"),
    ("map: m.yaml\nrobots: [[1, 1]]\nrobot: {preset: roomba}\n", "unknown robot preset 'roomba'"),
    ("map: m.yaml\nrobots: [[1, 1]]\nlaser: {range_min: 4.0}\n", "'range_max' (3.5) must be >"),
    ("map: m.yaml\nrobots: [[1, 1, 2, 3]]\n", "robots[0] must be [x, y] or [x, y, theta]"),
    ("map: m.yaml\nrobots: 3\n", "'robots' as a count needs 'patrol_map'"),
    ("map: m.yaml\npatrol_map: grid\nrobots: 3\n", "exactly one of 'map'"),
    ("map: nope.yaml\nrobots: [[1, 1]]\n", "nope.yaml: cannot read map YAML"),
    ("map: m.yaml\nrobots: [[-0.95, 1]]\n", "robots[0]: robot 0 at (-0.95, 1) m"),
    ("map: m.yaml\nrobots: [[1, 1], [1.1, 1]]\n", "overlaps robot 0"),
    ("map: [m.yaml\n", "w.yaml:2: invalid YAML"),
])
def test_bad_world_files_name_file_and_line(tmp_path, text, message):
    write_map(tmp_path)
    (tmp_path / "w.yaml").write_text(text)
    with pytest.raises(WorldError) as err:
        load_world(tmp_path / "w.yaml").build()
    assert message in str(err.value)


def test_world_from_a_patrol_map_with_a_robot_count(tmp_path):
    (tmp_path / "w.yaml").write_text("patrol_map: grid\nrobots: 4\n")
    cfg = load_world(tmp_path / "w.yaml")
    w = cfg.build()
    assert w.num_robots == 4 and len(set(cfg.poses)) == 4


def test_imported_cumberland(shared_maps, tmp_path):
    (tmp_path / "w.yaml").write_text(f"patrol_map: {shared_maps / 'cumberland'}\nrobots: 12\n")
    cfg = load_world(tmp_path / "w.yaml")
    assert cfg.resolution == 0.075 and cfg.occupied.shape == (499, 688)
    w = cfg.build()
    scans = w.scan_all()
    assert scans.shape == (12, 360) and np.isfinite(scans).any()


def test_resolved_world_is_explicit(tmp_path):
    """The C++ node reads only this form: every value explicit, the grid as a PGM."""
    import yaml

    write_map(tmp_path)
    (tmp_path / "w.yaml").write_text("map: m.yaml\nseed: 4\nrobot: {preset: patrolling_sim}\n"
                                     "laser: {beams: 181, fov: 3.14159, no_return: max}\n"
                                     "robots: [[1.0, 1.0], [3.0, 3.0, 1.5]]\n")
    cfg = load_world(tmp_path / "w.yaml")
    path = write_resolved(cfg, tmp_path / "out")
    doc = yaml.safe_load(path.read_text())
    assert doc[RESOLVED_KEY] == 1 and doc["seed"] == 4
    assert doc["robot"]["radius"] == 0.165 and doc["robot"]["max_linear_accel"] == math.inf
    assert doc["laser"]["angle_min"] == pytest.approx(-3.14159 / 2)
    assert doc["laser"]["angle_increment"] == pytest.approx(3.14159 / 180)
    assert doc["laser"]["no_return_range"] == 3.5 and doc["laser"]["rate"] == 5.0
    assert doc["robots"] == [[1.0, 1.0, 0.0], [3.0, 3.0, 1.5]]
    assert doc["origin"] == [-1.0, -2.0] and (doc["width"], doc["height"]) == (100, 100)
    pgm = (path.parent / doc["occupancy"]).read_bytes()
    header = b"P5\n100 100\n255\n"
    assert pgm.startswith(header)
    pixels = np.frombuffer(pgm[len(header):], dtype=np.uint8).reshape(100, 100)[::-1]
    assert np.array_equal(pixels == 0, cfg.occupied)  # image row 0 = top of the map
    assert "'robots': 2" in doc["summary"]


def test_resolver_command_names_file_and_line(tmp_path):
    import subprocess
    import sys

    write_map(tmp_path)
    bad = tmp_path / "w.yaml"
    bad.write_text("map: m.yaml\nrobots: [[1, 1]]\nlaser:\n  rnage_max: 4\n")
    proc = subprocess.run([sys.executable, "-m", "tpuaf_stage.resolve", str(bad),
                           str(tmp_path / "out")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert f"{bad}:4: unknown key(s) rnage_max in laser" in proc.stderr
    assert "Traceback" not in proc.stderr
    good = tmp_path / "g.yaml"
    good.write_text("map: m.yaml\nrobots: [[1, 1]]\n")
    proc = subprocess.run([sys.executable, "-m", "tpuaf_stage.resolve", str(good),
                           str(tmp_path / "out")], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.strip().endswith("world.resolved.yaml")
