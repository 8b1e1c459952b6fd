"""Map parameters a user can set (issue 34), and where each effective value came from.

Precedence, lowest first: the built-in default (MapSettings) or, for an imported patrolling_sim
map, the imported default (`imported_defaults`: scaled with the map's size and robot); the
map file (`settings:` of our map.yaml); the run's overrides (`--map-param KEY=VALUE` of `tpuaf
run`, `compare`, `fleet`, `maps`; the launch arg / node parameter `map_params`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from tpuaf.errors import MapError
from tpuaf.params import MAP_PARAMS as USER_PARAMS

POSITIVE = {"nominal_speed", "sensing_radius"}  # > 0; the others >= 0
MAX_VALUE = 1e6  # any value [m, m/s or -]: beyond it a typo, not a map

# Where a value came from (PatrolMap.setting_sources); an override names its own origin.
DEFAULT = "built-in default"  # MapSettings' (tpuaf.maps.model)
MAP_FILE = "map file"
IMPORTED = "imported default"
CLI = "--map-param"

# Imported patrolling_sim maps (their files carry no settings): the reference simulator's robot
# (tpuaf_stage.presets) and SPEC's values for them (r = 5 m, the paper's, on maps big enough for
# it; d_if = 2 m).
IMPORTED_ROBOT = "patrolling_sim"
IMPORTED_SENSING_M = 5.0  # [m] the paper's r
IMPORTED_INTERFERENCE_M = 2.0  # [m] SPEC's default d_if
# r at most this fraction of the graph's longer side [-]: on a small map the paper's 5 m would
# sense most of it, and X (the signal TPUAF is built on) would stay near 0
SENSING_SPAN_FRACTION = 0.25


def imported_sensing(span_m: float) -> tuple[float, str]:
    """(r [m], its source) of an imported map whose vertices span `span_m` [m] on their longer
    side: the paper's 5 m, or SENSING_SPAN_FRACTION of the span (to 0.1 m) when smaller."""
    scaled = max(round(SENSING_SPAN_FRACTION * span_m, 1), 0.1)  # to 0.1 m
    if span_m > 0 and scaled < IMPORTED_SENSING_M:
        return scaled, (f"{IMPORTED}: {SENSING_SPAN_FRACTION:g} x the graph's {span_m:.1f} m "
                        f"span (the paper's {IMPORTED_SENSING_M:g} m would sense most of it)")
    return IMPORTED_SENSING_M, f"{IMPORTED}: the paper's r"


def imported_defaults(positions: np.ndarray) -> dict[str, tuple[Any, str]]:
    """{setting: (value, source)} of an imported map with vertices at `positions` (n, 2) [m]:
    the reference robot's speed and radius, r = 5 m scaled down on small maps
    (`imported_sensing`) and d_if = 2 m (SPEC); `--map-param` overrides any of them."""
    from tpuaf_stage.presets import ROBOT_PRESETS

    robot = ROBOT_PRESETS[IMPORTED_ROBOT]
    pos = np.asarray(positions, dtype=float).reshape(-1, 2)
    span = float((pos.max(axis=0) - pos.min(axis=0)).max()) if len(pos) else 0.0
    radius = float(robot["radius"])
    return {
        "nominal_speed": (float(robot["max_linear_speed"]),
                          f"{IMPORTED}: {IMPORTED_ROBOT} robot's limit"),
        "sensing_radius": imported_sensing(span),
        "interference_distance": (IMPORTED_INTERFERENCE_M, f"{IMPORTED}: SPEC's d_if"),
        "robot_radius": (radius, f"{IMPORTED}: {IMPORTED_ROBOT} robot"),
    }


def _number(key: str, raw: Any, origin: str) -> float:
    from tpuaf.maps.occupancy import as_number

    value = as_number(raw)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not math.isfinite(value):
        raise MapError(f"{origin}: {key} must be a finite number, got {raw!r}")
    value = float(value)
    low_ok = value > 0 if key in POSITIVE else value >= 0
    if not low_ok or value > MAX_VALUE:
        low = "> 0" if key in POSITIVE else ">= 0"
        raise MapError(f"{origin}: {key} must be {low} and <= {MAX_VALUE:g}, got {value:g}")
    return value


def check_map_params(values: Mapping[str, Any], origin: str) -> dict[str, Any]:
    """{key: value} checked and converted (numbers; growth_coefficients a non-empty list of
    numbers or a comma-separated text); MapError naming `origin` and the key."""
    if not isinstance(values, Mapping):
        raise MapError(f"{origin}: expected a mapping KEY: VALUE, got {values!r}")
    out: dict[str, Any] = {}
    for key, raw in values.items():
        if key not in USER_PARAMS:
            raise MapError(f"{origin}: unknown map parameter {key!r} (valid: "
                           f"{', '.join(USER_PARAMS)})")
        if key == "growth_coefficients":
            items = raw
            if isinstance(raw, str):
                items = [t for t in raw.strip().strip("[]").replace(",", " ").split() if t]
            if not isinstance(items, (list, tuple)) or not items:
                raise MapError(f"{origin}: growth_coefficients must be a non-empty list of "
                               f"numbers (e.g. 1.0,0.6), got {raw!r}")
            out[key] = [_number(key, v, origin) for v in items]
        else:
            out[key] = _number(key, raw, origin)
    return out


def parse_map_params(items: Iterable[str], origin: str = CLI) -> dict[str, Any]:
    """KEY=VALUE texts (`--map-param`, repeatable; the last of a key wins) checked."""
    values: dict[str, str] = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        if not sep or not key.strip() or not value.strip():
            raise MapError(f"{origin}: expected KEY=VALUE (keys: {', '.join(USER_PARAMS)}), "
                           f"got {item!r}")
        values[key.strip()] = value.strip()
    return check_map_params(values, origin)


def apply_map_params(patrol_map, values: Mapping[str, Any], origin: str):
    """`patrol_map` with `values` (checked by `check_map_params`) over its settings, each
    recorded as coming from `origin`. Changes the map in place (fresh settings object) and
    returns it."""
    if not values:
        return patrol_map
    checked = check_map_params(values, origin)
    patrol_map.settings = replace(patrol_map.settings, **checked)
    patrol_map.setting_sources = {**patrol_map.setting_sources,
                                  **{k: origin for k in checked}}
    return patrol_map


def effective_params(patrol_map) -> dict[str, dict[str, Any]]:
    """{key: {"value", "unit", "source"}} of every user parameter (and the robot radius)."""
    s = patrol_map.settings
    sources = patrol_map.setting_sources
    keys = list(USER_PARAMS) + ["robot_radius"]
    units = {**{k: u for k, (u, _) in USER_PARAMS.items()}, "robot_radius": "m"}
    return {k: {"value": getattr(s, k), "unit": units[k], "source": sources.get(k, DEFAULT)}
            for k in keys}


def format_params(name: str, params: Mapping[str, Mapping[str, Any]]) -> str:
    """Lines of `tpuaf maps`: each effective parameter, its unit and where it came from."""
    lines = [f"parameters of {name}:"]
    for key, p in params.items():
        value = p["value"]
        text = (", ".join(f"{v:g}" for v in value) if isinstance(value, (list, tuple))
                else f"{value:g}")
        unit = "" if p["unit"] == "-" else f" {p['unit']}"
        lines.append(f"  {key:<22} {text + unit:<14} ({p['source']})")
    return "\n".join(lines)
