"""Named robot and laser presets of the simulator. Units: m, s, rad.

Robot presets (key `robot.preset` of a world file):
- burger: TurtleBot3 Burger-like (default). 0.105 m disc, 0.22 m/s, 2.84 rad/s; the
  accelerations are the TurtleBot3 navigation limits (2.5 m/s^2, 3.2 rad/s^2).
- waffle, waffle_pi: TurtleBot3 Waffle and Waffle Pi-like (the same base). 0.153 m disc,
  0.26 m/s, 1.82 rad/s. The names are those of TURTLEBOT3_MODEL.
- patrolling_sim: the reference simulator's robot: 0.33 m disc (radius 0.165 m), 1 m/s;
  1.57 rad/s and unlimited accelerations are our choice (the reference gives no figure).

Laser presets (key `laser.preset`):
- lds01: LDS-01-like (default): 360 beams at 1 degree over the full circle starting at 0 rad,
  0.12-3.5 m, 5 Hz, 0.01 m noise, 'inf' for no return (the real LDS-01 reads 0.0: set
  `no_return: zero`), mounted at (-0.032, 0, 0.172) m as on the Burger.
- lds01_waffle: the same laser at the Waffle Pi mounting (-0.064, 0, 0.122) m.
- wide: a generic long-range laser: 360 beams over 2 pi, 0.05-30 m, 10 Hz, no noise, centred.
"""

import math

INF = math.inf

_ROBOT_COMMON = {"odom_linear_noise": 0.0, "odom_angular_noise": 0.0, "base_link_z": 0.010}

ROBOT_PRESETS: dict[str, dict] = {
    "burger": {"radius": 0.105, "max_linear_speed": 0.22, "max_angular_speed": 2.84,
               "max_linear_accel": 2.5, "max_angular_accel": 3.2, **_ROBOT_COMMON},
    "waffle_pi": {"radius": 0.153, "max_linear_speed": 0.26, "max_angular_speed": 1.82,
                  "max_linear_accel": 2.5, "max_angular_accel": 3.2, **_ROBOT_COMMON},
    "waffle": {"radius": 0.153, "max_linear_speed": 0.26, "max_angular_speed": 1.82,
               "max_linear_accel": 2.5, "max_angular_accel": 3.2, **_ROBOT_COMMON},
    "patrolling_sim": {"radius": 0.165, "max_linear_speed": 1.0, "max_angular_speed": 1.57,
                       "max_linear_accel": INF, "max_angular_accel": INF, **_ROBOT_COMMON},
}

_LDS01 = {"beams": 360, "fov": 2 * math.pi, "angle_min": None, "range_min": 0.12,
          "range_max": 3.5, "noise_std": 0.01, "rate": 5.0, "no_return": "inf",
          "x": -0.032, "y": 0.0, "z": 0.172, "yaw": 0.0}

LASER_PRESETS: dict[str, dict] = {
    "lds01": _LDS01,
    "lds01_waffle": {**_LDS01, "x": -0.064, "z": 0.122},
    "wide": {"beams": 360, "fov": 2 * math.pi, "angle_min": None, "range_min": 0.05,
             "range_max": 30.0, "noise_std": 0.0, "rate": 10.0, "no_return": "inf",
             "x": 0.0, "y": 0.0, "z": 0.1, "yaw": 0.0},
}
