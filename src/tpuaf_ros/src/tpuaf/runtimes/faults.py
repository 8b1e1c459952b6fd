"""Fault injection shared by the graph and physics runtimes (`tpuaf run --fail/--stall`).

- death (`--fail ROBOT@TIME`): from TIME [s] the robot no longer moves, senses, decides or sends;
  its teammates are not told (their strategies must notice the silence);
- `--fail-random K`: K distinct robots die at times drawn uniformly in [duration / 10,
  duration / 2], seeded by the run seed (rng stream [seed, 3]);
- stall (`--stall ROBOT@TIME`): from TIME the robot stops moving for good but keeps deciding and
  talking: its navigator gives up on goals it cannot reach (after `stall_give_up_s` in the
  graph runtime, the navigator's own timeouts in the physics runtime), it re-decides, and it
  dwells on the vertex it stands on when it picks it (no motion needed; a dwell, not a visit).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from tpuaf.errors import TpuafError

DEATH, STALL = "death", "stall"


class FaultError(TpuafError):
    """A fault option is malformed or impossible; the message names it."""


@dataclass(frozen=True, order=True)
class Fault:
    time_s: float
    robot: int
    kind: str  # DEATH or STALL

    def to_dict(self) -> dict:
        return {"kind": self.kind, "robot": self.robot, "time_s": self.time_s}


_SPEC = re.compile(r"^\s*(\d+)\s*@\s*([0-9.eE+-]+)\s*$")


def parse_fault(text: str, option: str = "--fail") -> tuple[int, float]:
    """'ROBOT@TIME' -> (robot index, time [s])."""
    m = _SPEC.match(str(text))
    if not m:
        raise FaultError(f"{option} expects ROBOT@TIME (robot index @ seconds), got '{text}'")
    try:
        time_s = float(m.group(2))
    except ValueError:
        raise FaultError(f"{option}: bad time in '{text}'") from None
    if not (math.isfinite(time_s) and time_s >= 0):
        raise FaultError(f"{option}: the time must be a finite number >= 0 s, got '{text}'")
    return int(m.group(1)), time_s


def _pairs(items, option: str) -> list[tuple[int, float]]:
    out = []
    for item in items or []:
        if isinstance(item, str):
            out.append(parse_fault(item, option))
        else:
            try:
                robot, time_s = item
            except (TypeError, ValueError):
                raise FaultError(f"{option} expects (robot, time) pairs, got {item!r}") from None
            if isinstance(robot, bool) or not isinstance(robot, (int, np.integer)):
                raise FaultError(f"{option}: the robot must be an integer index, got {robot!r}")
            if not (isinstance(time_s, (int, float)) and math.isfinite(time_s) and time_s >= 0):
                raise FaultError(f"{option}: the time must be a finite number >= 0 s, "
                                 f"got {time_s!r}")
            out.append((int(robot), float(time_s)))
    return out


def resolve_faults(fail, fail_random: int, stall, robots: int, duration_s: float,
                   seed: int) -> list[Fault]:
    """The run's faults in time order; FaultError on a robot index outside the team, a time
    after the run, a robot that dies twice, or more random deaths than robots left."""
    deaths = _pairs(fail, "--fail")
    stalls = _pairs(stall, "--stall")
    for option, pairs in (("--fail", deaths), ("--stall", stalls)):
        for robot, time_s in pairs:
            if not 0 <= robot < robots:
                raise FaultError(f"{option} {robot}@{time_s:g}: robot index must be in "
                                 f"0..{robots - 1}")
            if time_s > duration_s:
                raise FaultError(f"{option} {robot}@{time_s:g}: time is after the run's end "
                                 f"({duration_s:g} s)")
    dead = [r for r, _ in deaths]
    if len(set(dead)) != len(dead):
        raise FaultError(f"--fail names a robot twice: {sorted(dead)}")
    stalled = [r for r, _ in stalls]
    if len(set(stalled)) != len(stalled):
        raise FaultError(f"--stall names a robot twice: {sorted(stalled)}")
    if isinstance(fail_random, bool) or not isinstance(fail_random, (int, np.integer)) or \
            fail_random < 0:
        raise FaultError(f"--fail-random must be an integer >= 0, got {fail_random!r}")
    left = [r for r in range(robots) if r not in dead]
    if fail_random > len(left):
        raise FaultError(f"--fail-random {fail_random}: only {len(left)} robot(s) are not "
                         "already failed")
    faults = [Fault(t, r, DEATH) for r, t in deaths] + [Fault(t, r, STALL) for r, t in stalls]
    if fail_random:
        rng = np.random.default_rng([int(seed), 3])
        chosen = rng.choice(len(left), size=int(fail_random), replace=False)
        times = rng.uniform(0.1 * duration_s, 0.5 * duration_s, size=int(fail_random))
        faults += [Fault(float(t), left[int(k)], DEATH) for k, t in zip(chosen, times, strict=True)]
    return sorted(faults)
