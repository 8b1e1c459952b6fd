"""The ROS fleet (`tpuaf fleet`: roscpp tpuaf_stage + N patrol_agent + monitor + rosbag record of
the default topics) in lock-step, for N = 4, 8, 12 on grid and cumberland, on an idle machine and
under a CPU hog (2 busy-loop processes, one per core).

Per run: real-time factor (simulated s per wall s from the run's start), visits, health = fleet
visits / reference visits (reference: `tpuaf run --runtime physics` when that runtime exists,
else the graph runtime; the report says which), unresponsive-agent events, deaths, agent CPU
per control tick (sampled from /proc: user + system time of the patrol_agent processes over all
their 10 Hz pose ticks), bag size.
Writes benchmarks/results/fleet.md (and fleet.json). Usage:
    .venv/bin/python benchmarks/bench_fleet.py [--quick] [--duration 300] [--loads idle,hog]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import RESULTS  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
MAPS = {"grid": "grid", "cumberland": "/work/shared/maps/patrolling_sim/cumberland"}
CLK_TCK = os.sysconf("SC_CLK_TCK")
CONTROL_RATE_HZ = 10.0  # pose ticks per simulated second (fleet.launch odom_rate)
# Agent CPU per tick = their CPU time / the lock-step answers the simulator received.


def clean_env() -> dict:
    return {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}


def start_hog(cores: int = 2) -> list[subprocess.Popen]:
    """Busy-loop processes (one per core) in their own sessions; stop_hog kills them by PID."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"], start_new_session=True,
                             stdin=subprocess.DEVNULL) for _ in range(cores)]


def stop_hog(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(p.pid, signal.SIGKILL)
        p.wait(10)


def _children() -> dict[int, list[int]]:
    out: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            out.setdefault(ppid, []).append(int(entry.name))
    return out


def agent_cpu_sampler(root_pid: int, stop: threading.Event, cpu: dict[int, float]) -> None:
    """Keep the latest user + system CPU [s] of every patrol_agent descendant of root_pid."""
    while not stop.is_set():
        children = _children()
        todo, found = [root_pid], []
        while todo:
            for c in children.get(todo.pop(), []):
                found.append(c)
                todo.append(c)
        for pid in found:
            try:
                cmd = Path(f"/proc/{pid}/cmdline").read_bytes()
                if b"patrol_agent" not in cmd:
                    continue
                fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
                cpu[pid] = (int(fields[11]) + int(fields[12])) / CLK_TCK
            except (OSError, IndexError, ValueError):
                continue
        stop.wait(0.5)


def fleet(map_ref: str, n: int, duration: float, out: Path, extra=()) -> dict:
    cmd = [TPUAF, "fleet", "--map", map_ref, "--robots", str(n), "--duration", str(duration),
           "--seed", "0", "--out", str(out), "--quiet", *extra]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=clean_env(), cwd=REPO, start_new_session=True)
    stop, cpu = threading.Event(), {}
    sampler = threading.Thread(target=agent_cpu_sampler, args=(proc.pid, stop, cpu), daemon=True)
    sampler.start()
    try:
        stdout, _ = proc.communicate(timeout=duration + 900)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGINT)
        stdout, _ = proc.communicate(timeout=120)
    finally:
        stop.set()
        sampler.join()
    if not (out / "fleet_timing.json").is_file() or not (out / "summary.json").is_file():
        return {"ok": False, "rtf": None, "visits": 0, "deaths": None, "unresponsive": None,
                "agent_cpu_ms_per_tick": None, "agent_cpu_s": sum(cpu.values()),
                "agents_seen": len(cpu), "bag_mb": None, "tail": stdout[-600:]}
    timing = json.loads((out / "fleet_timing.json").read_text())
    summary = json.loads((out / "summary.json").read_text())
    sim = json.loads((out / "simulator.json").read_text()) if (out / "simulator.json").is_file() \
        else {}
    ticks = sum(sim.get("answers_per_robot", [])) or n * sim.get("sim_time_s", 0.0) * CONTROL_RATE_HZ
    bag = out / "run.bag"
    return {"ok": proc.returncode == 0, "rtf": timing["real_time_factor"],
            "visits": summary["visits"], "deaths": summary.get("deaths", 0),
            "unresponsive": summary.get("unresponsive_events", 0),
            "agent_cpu_ms_per_tick": 1000 * sum(cpu.values()) / ticks if ticks else None,
            "agent_cpu_s": sum(cpu.values()), "agents_seen": len(cpu),
            "bag_mb": bag.stat().st_size / 1e6 if bag.is_file() else None,
            "tail": stdout[-600:]}


def reference_visits(map_ref: str, n: int, duration: float, runtime: str,
                     travel: str = "declared") -> int | None:
    for _attempt in range(2):
        with tempfile.TemporaryDirectory() as tmp:
            cmd = [TPUAF, "run", "--map", map_ref, "--robots", str(n), "--duration",
                   str(duration), "--seed", "0", "--travel", travel, "--out", f"{tmp}/ref"]
            if runtime != "graph":
                cmd += ["--runtime", runtime]
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=1800, cwd=REPO)
            if proc.returncode == 0:
                return json.loads(Path(f"{tmp}/ref/summary.json").read_text())["visits"]
            print(f"reference run failed: {proc.stderr[-500:]}", file=sys.stderr)
    return None


def wait_for_workspace(timeout_s: float = 300.0) -> None:
    """Others rebuild the shared workspace: wait until the core module imports."""
    deadline = time.monotonic() + timeout_s
    while subprocess.run([sys.executable, "-c", "import tpuaf_core, tpuaf.cli"],
                         capture_output=True).returncode != 0:
        if time.monotonic() > deadline:
            raise SystemExit("the workspace does not import (tpuaf_core being rebuilt?)")
        time.sleep(5)


def physics_available() -> bool:
    text = subprocess.run([TPUAF, "run", "--help"], capture_output=True, text=True).stdout
    return "--runtime" in text and "physics" in text


def uptime() -> str:
    return Path("/proc/loadavg").read_text().split(" ")[:3].__str__()


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--duration", type=float, default=300.0, help="simulated s per run")
    ap.add_argument("--quick", action="store_true", help="grid, N = 4 only")
    ap.add_argument("--loads", default="idle,hog")
    ap.add_argument("--robots", default="4,8,12")
    ap.add_argument("--maps", default="grid,cumberland")
    ap.add_argument("--reference", default="auto", help="physics, graph or auto")
    ap.add_argument("--append", action="store_true",
                    help="keep the other configurations' rows of the existing fleet.json")
    args = ap.parse_args()
    maps = {"grid": MAPS["grid"]} if args.quick else {m: MAPS[m] for m in args.maps.split(",")}
    ns = [4] if args.quick else [int(x) for x in args.robots.split(",")]
    loads = args.loads.split(",")
    runtime = args.reference
    if runtime == "auto":
        runtime = "physics" if physics_available() else "graph"
    rows = []
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    load_before = uptime()
    with tempfile.TemporaryDirectory() as tmp:
        for name, ref in maps.items():
            for n in ns:
                wait_for_workspace()
                ref_visits = reference_visits(ref, n, args.duration, runtime)
                # The promise: the graph runtime on lengths a robot can drive.
                graph_visits = reference_visits(ref, n, args.duration, "graph", "planned")
                for load in loads:
                    wait_for_workspace()
                    hog = start_hog() if load == "hog" else []
                    try:
                        la = uptime()
                        r = fleet(ref, n, args.duration, Path(tmp) / f"{name}{n}{load}{len(rows)}")
                    finally:
                        stop_hog(hog)
                    r.update(map=name, n=n, load=load, loadavg=la, ref_visits=ref_visits,
                             reference=runtime, started=started, graph_visits=graph_visits,
                             health=r["visits"] / ref_visits if ref_visits else None,
                             health_graph=r["visits"] / graph_visits if graph_visits else None)
                    rows.append(r)
                    print(json.dumps({k: v for k, v in r.items() if k != "tail" or not r["ok"]}),
                          flush=True)
    name = "fleet_quick" if args.quick else "fleet"
    if args.append and (RESULTS / f"{name}.json").is_file():
        done = {(r["map"], r["n"], r["load"]) for r in rows}
        old = [r for r in json.loads((RESULTS / f"{name}.json").read_text())
               if (r["map"], r["n"], r["load"]) not in done]
        rows = sorted(old + rows, key=lambda r: (list(MAPS).index(r["map"]), r["n"],
                                                 loads.index(r["load"]) if r["load"] in loads
                                                 else 9))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=REPO).stdout.strip()
    lines = [f"# ROS fleet: lock-step, roscpp simulator\n\nOne run per row on {os.cpu_count()} "
             f"cores, commit {commit}.",
             f"Run {started}; `.venv/bin/python benchmarks/bench_fleet.py --duration "
             f"{args.duration:g}`; load average before: {load_before}.",
             "",
             f"Lock-step (default of `tpuaf fleet`), as fast as possible, bag recorded (default "
             f"topics), seed 0, {args.duration:g} simulated s per run. Health = fleet visits / "
             f"`{runtime}` runtime visits (same map, N, seed)"
             + ("" if runtime == "physics" else "; the physics runtime was not available, so "
                "the reference is the graph runtime (ideal motion, no physics)") + ". "
             "Health vs graph = fleet visits / graph runtime visits on planned path lengths "
             "(`--travel planned`): what the patrol promises, against what the fleet delivers. "
             "Hog = 2 busy-loop processes (one per core) for the whole run.",
             "",
             "| map | N | load | RTF | visits | ref visits | health | graph visits | "
             "health vs graph | unresponsive | deaths | agent CPU / tick | bag | "
             "load avg at start |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        cpu = f"{r['agent_cpu_ms_per_tick']:.2f} ms" if r["agent_cpu_ms_per_tick"] else "-"
        bag = f"{r['bag_mb']:.1f} MB" if r["bag_mb"] else "-"
        rtf = f"{r['rtf']:.1f}x" if r["rtf"] else "failed"
        health = f"{r['health']:.3f}" if r["health"] is not None else "-"
        hg = r.get("health_graph")
        health_graph = f"{hg:.3f}" if hg is not None else "-"
        lines.append(f"| {r['map']} | {r['n']} | {r['load']} | {rtf} | {r['visits']} | "
                     f"{r['ref_visits']} | {health} | {r.get('graph_visits', '-')} | "
                     f"{health_graph} | {r['unresponsive']} | {r['deaths']} | "
                     f"{cpu} | {bag} | {r['loadavg']} |")
    lines += ["", f"Load average after: {uptime()}. The machine is shared with other "
              "developers: RTF moves with their load; health and visits should not (lock-step)."]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{name}.md").write_text("\n".join(lines) + "\n")
    (RESULTS / f"{name}.json").write_text(json.dumps(
        [{k: v for k, v in r.items() if k != "tail"} for r in rows], indent=2))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
