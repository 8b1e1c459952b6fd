"""Issue 33 item 6 probe: hostile team traffic against a lock-step fleet (`probe_hostile.py --team`).

Each class is one `tpuaf fleet` (grid, 3 robots, 60 s of sim time at 2x real time, lock-step,
seed 5) on a master of its own, with a rogue node started beside it; the clean run has none.
Classes (the rogue begins 2 s of wall time after the run start):

- `spoofed id`: node /robot_2/rogue (robot 2's namespace) publishes as robot 1, 5 msg/s for
  10 s: AgentEvents (GOAL, REACHED, HEARTBEAT) and Visit, Intention team messages;
- `flood`: node /rogue publishes as robot 1 at 50 msg/s for 10 s (the same messages);
- `off-clock`: node /robot_1/rogue (robot 1's own namespace: it passes the sender check)
  publishes as robot 1, 5 msg/s for 10 s, stamped 1000 s or 40 s after the clock (beyond the
  agents' and the monitor's 30 s; 1000 s before cannot be stamped in a 60 s run: stamps clamp
  to 0, which the agents accept for the first 30 s - a node in a robot's namespace is trusted,
  docs/FLEET.md "Hostile traffic");
- `rogue start`: node /rogue latches a /fleet/start 50 s before the real one.

Per class: the visits against the clean run (the lock-step run is reproducible: identical when
the attack has no effect), false deaths, the monitor's refusals by reason (summary `rejected`),
the agents' (summary `rejected_by_agents`) and whether the summary says `suspect_traffic`.
"""

from __future__ import annotations

import json
import shlex
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from tests.ros.conftest import VENV_PYTHON, ros_master  # noqa: E402

TPUAF = str(REPO / ".venv" / "bin" / "tpuaf")
ROBOTS, DURATION, SEED, RTF = 3, 60.0, 5, 2.0
TARGET_SHARE = 0.02  # visits within this share of the clean run's

ROGUE = """
import sys, time
import rospy
from tpuaf.maps import load_map
from tpuaf_ros.msg import AgentEvent, Intention, RunStart, Visit

kind, rate, seconds, offset = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
time.sleep(5.0)  # the launch sets /use_sim_time first: our stamps on the simulated clock
rospy.init_node("rogue")
ids = [int(v) for v in load_map("grid").vertex_ids]
events = rospy.Publisher("/fleet/agent_events", AgentEvent, queue_size=100)
visits = rospy.Publisher("/team/visits", Visit, queue_size=100)
intents = rospy.Publisher("/team/intentions", Intention, queue_size=100)
start = rospy.Publisher("/fleet/start", RunStart, queue_size=1, latch=True)
real = rospy.wait_for_message("/fleet/start", RunStart, timeout=300)
while rospy.Time.now() < real.header.stamp and not rospy.is_shutdown():
    time.sleep(0.05)
time.sleep(2.0)
sent, k = 0, 0
if kind == "start":
    fake = RunStart(announcer="/rogue", robots=3, team=["robot_0", "robot_1", "robot_2"])
    fake.header.stamp = rospy.Time.from_sec(max(0.0, real.header.stamp.to_sec() - 50.0))
    start.publish(fake)
    sent = 1
    time.sleep(3.0)
end = time.monotonic() + seconds
while kind != "start" and time.monotonic() < end and not rospy.is_shutdown():
    now = rospy.Time.from_sec(max(0.0, rospy.Time.now().to_sec() + offset))
    v, w = ids[k % len(ids)], ids[(k + 1) % len(ids)]
    e = AgentEvent(robot="robot_1", robot_index=1, event=(1, 2, 4)[k % 3], vertex=v,
                   from_vertex=-1)
    e.header.stamp = now
    events.publish(e)
    m = Visit(robot="robot_1", robot_index=1, vertex=v, next_vertex=w)
    m.header.stamp = now
    visits.publish(m)
    i = Intention(robot="robot_1", robot_index=1, from_vertex=v, vertex=w,
                  expected_arrival=now.to_sec() + 5.0, travel_time=5.0)
    i.header.stamp = now
    intents.publish(i)
    sent += 3
    k += 1
    time.sleep(1.0 / rate)
print(f"rogue sent {sent} messages", flush=True)
"""

# class -> (rogue namespace, argv: kind, rate [msg/s], seconds of wall time, stamp offset [s])
CLASSES = {
    "clean": None,
    "spoofed id": ("/robot_2", ["flood", "5", "10", "0"]),
    "flood": ("/", ["flood", "50", "10", "0"]),
    "off-clock (+1000 s)": ("/robot_1", ["flood", "5", "10", "1000"]),
    "off-clock (+40 s)": ("/robot_1", ["flood", "5", "10", "40"]),
    "rogue start": ("/", ["start", "1", "0", "0"]),
}


def fleet(tmp: Path, name: str, rogue) -> dict:
    """One fleet (roslaunch as `tpuaf fleet` prepares it) with the rogue; its summary."""
    out = tmp / name.replace(" ", "_").replace("(", "").replace(")", "")
    prep = subprocess.run([TPUAF, "fleet", "--map", "grid", "--robots", str(ROBOTS),
                           "--duration", str(DURATION), "--seed", str(SEED), "--rtf", str(RTF),
                           "--out", str(out), "--prepare-only"],
                          capture_output=True, text=True, timeout=120)
    if prep.returncode != 0:
        raise RuntimeError(prep.stderr)
    cmd = shlex.split(prep.stdout.strip().splitlines()[-1])
    with ros_master(tmp / f"ros_{out.name}") as ros:
        ros.start(cmd, name="fleet")
        if rogue is not None:
            ns, argv = rogue
            script = ros.home / "rogue.py"
            script.write_text(ROGUE)
            ros.start([str(VENV_PYTHON), str(script), *argv, f"__ns:={ns}"], name="rogue")
        summary = out / "summary.json"
        deadline = time.monotonic() + 400
        while time.monotonic() < deadline and not summary.is_file():
            time.sleep(1.0)
        time.sleep(3.0)
        said = ros.output("rogue") if rogue is not None else ""
        ros.stop_all()
    if not summary.is_file():
        raise RuntimeError(f"{name}: no summary.json")
    result = json.loads(summary.read_text())
    result["rogue_sent"] = int(said.split("rogue sent ")[1].split()[0]) if "rogue sent" in said \
        else 0
    visits_csv = out / "visits.csv"
    result["visits_csv"] = visits_csv.read_text() if visits_csv.is_file() else ""
    return result


def run(tmp: Path) -> list[dict]:
    rows = []
    for name, rogue in CLASSES.items():
        t0 = time.monotonic()
        s = fleet(tmp, name, rogue)
        rows.append({"class": name, "visits": s["visits"], "deaths": s["deaths"],
                     "idleness_max_s": s["idleness_max_s"], "sent": s["rogue_sent"],
                     "monitor_refused": s["rejected"]["by_reason"],
                     "agents_refused": s.get("rejected_by_agents", {}).get("by_reason", {}),
                     "suspect": s["suspect_traffic"], "visits_csv": s["visits_csv"],
                     "wall_s": round(time.monotonic() - t0, 1)})
        print(f"{name}: {rows[-1]['visits']} visits, deaths {s['deaths']}, monitor refused "
              f"{rows[-1]['monitor_refused']}, agents refused {rows[-1]['agents_refused']}",
              file=sys.stderr)
    return rows


def _counts(d: dict) -> str:
    return ", ".join(f"{k} {v}" for k, v in d.items()) or "0"


def report(rows: list[dict]) -> str:
    clean = rows[0]
    lines = ["## Hostile team traffic (issue 33 item 6): `probe_hostile.py --team`\n",
             f"Lock-step fleet, grid, {ROBOTS} robots, {DURATION:g} s at {RTF:g}x real time, seed "
             f"{SEED}, one run per class on a master of its own (module docstring of "
             "benchmarks/hostile_team.py). Visits against the clean run of the same seed (target "
             f"within {TARGET_SHARE:.0%}); false deaths = deaths beyond the clean run's; "
             "refusals by reason, of the monitor (`rejected`) and of the agents "
             "(`rejected_by_agents`, summed over the agents: each refuses what reaches it).\n",
             "| class | rogue messages | visits | vs clean | same visit sequence | false deaths "
             "| I_max [s] | monitor refused | agents refused | suspect |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        share = (r["visits"] - clean["visits"]) / max(1, clean["visits"])
        lines.append(f"| {r['class']} | {r['sent']} | {r['visits']} | {share:+.1%} | "
                     f"{'yes' if r['visits_csv'] == clean['visits_csv'] else 'no'} | "
                     f"{r['deaths'] - clean['deaths']} | {r['idleness_max_s']:.1f} | "
                     f"{_counts(r['monitor_refused'])} | {_counts(r['agents_refused'])} | "
                     f"{'yes' if r['suspect'] else 'no'} |")
    worst = max(abs(r["visits"] - clean["visits"]) / max(1, clean["visits"]) for r in rows)
    lines.append(f"\nWorst visits difference: {worst:.1%} (target {TARGET_SHARE:.0%}: "
                 f"{'met' if worst <= TARGET_SHARE else 'NOT met'}).")
    return "\n".join(lines) + "\n"


MARK = "<!-- team traffic: benchmarks/hostile_team.py -->"


def write_section(md: Path, text: str) -> None:
    """Put `text` in `md` after MARK (replacing what follows it), or append it."""
    old = md.read_text() if md.is_file() else ""
    head = old.split(MARK)[0].rstrip("\n")
    md.write_text((head + "\n\n" if head else "") + MARK + "\n\n" + text)


def main(md: Path, tmp: Path) -> None:
    import datetime as dt
    import os

    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=REPO, check=False).stdout.strip()
    start = time.monotonic()
    rows = run(tmp)
    text = report(rows) + (
        f"\nMeasured {dt.datetime.now().strftime('%Y-%m-%d %H:%M')} on {os.cpu_count()} cores, "
        f"commit {commit}, one run per class, wall time {time.monotonic() - start:.0f} s, load "
        f"average at the end {os.getloadavg()[0]:.1f}. Reproduce: `.venv/bin/python "
        "benchmarks/probe_hostile.py --team` (after `source devel/setup.bash`).\n")
    print(text)
    write_section(md, text)
    md.with_name("hostile_team.json").write_text(json.dumps(
        [{k: v for k, v in r.items() if k != "visits_csv"} for r in rows], indent=1) + "\n")
