"""Wall time of the whole test suite (`bash launch_scripts/test.sh`, what CI runs) with its phases,
the pytest workers, the machine's load while it ran and the slowest tests; written to
benchmarks/results/suite.md.

    .venv/bin/python benchmarks/bench_suite.py                      # this checkout
    .venv/bin/python benchmarks/bench_suite.py --clone /work/main --repo /work/suite_check
        # a fresh clone (it needs ../shared beside it): setup builds the workspace, measured too
    .venv/bin/python benchmarks/bench_suite.py --workers 3 -- tests/ros   # args after -- to pytest

First `bash launch_scripts/setup.sh` alone (in a fresh clone: configure and build, minutes), then
`bash launch_scripts/test.sh` (its setup then only checks) = "without setup"; both = "with setup".
Phases of test.sh are told apart by the first line each prints (ctest: "Test project", pytest:
"test session starts"). Load: the 1-min load average of /proc/loadavg, sampled every 5 s.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import threading
import time
from datetime import UTC, datetime
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
SLOWEST = 20


def load1() -> float:
    return float(Path("/proc/loadavg").read_text().split()[0])


class LoadSampler(threading.Thread):
    """1-min load average every `period_s` until stopped."""

    def __init__(self, period_s: float = 5.0):
        super().__init__(daemon=True)
        self.period_s = period_s
        self.samples: list[float] = []
        self._halt = threading.Event()

    def run(self) -> None:
        while not self._halt.is_set():
            self.samples.append(load1())
            self._halt.wait(self.period_s)

    def stop(self) -> None:
        self._halt.set()
        self.join()


def run_suite(repo: Path, workers: int | None, pytest_args: list[str], log: Path) -> dict:
    env = dict(os.environ)
    if workers is not None:
        env["TPUAF_TEST_WORKERS"] = str(workers)
    cmd = ["bash", "launch_scripts/test.sh", f"--durations={SLOWEST}", "--durations-min=0",
           "-p", "no:cacheprovider", *pytest_args]
    marks: dict[str, float] = {}
    lines: list[str] = []
    sampler = LoadSampler()
    load_start = Path("/proc/loadavg").read_text().split()[:3]
    sampler.start()
    t_setup = time.monotonic()
    with log.open("w") as out:
        setup = subprocess.run(["bash", "launch_scripts/setup.sh"], cwd=repo, env=env,
                               stdout=out, stderr=subprocess.STDOUT)
        if setup.returncode:
            sampler.stop()
            raise SystemExit(f"error: launch_scripts/setup.sh failed (exit {setup.returncode}); "
                             f"see {log}")
    t0 = time.monotonic()
    with log.open("a") as out:
        proc = subprocess.Popen(cmd, cwd=repo, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, bufsize=1)
        try:
            for line in proc.stdout:
                now = time.monotonic() - t0
                out.write(line)
                lines.append(line.rstrip("\n"))
                if "ctest" not in marks and line.startswith("Test project"):
                    marks["ctest"] = now
                if "pytest" not in marks and "test session starts" in line:
                    marks["pytest"] = now
            code = proc.wait()
        except BaseException:
            proc.terminate()
            proc.wait(60)
            raise
    total = time.monotonic() - t0
    sampler.stop()
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {"cmd": cmd, "code": code, "total_s": total, "setup_s": t0 - t_setup,
            "marks": marks, "lines": lines,
            "load": sampler.samples, "load_start": load_start,
            "load_end": Path("/proc/loadavg").read_text().split()[:3],
            "cpu_s": usage.ru_utime + usage.ru_stime, "workers": env.get("TPUAF_TEST_WORKERS")}


def slowest(lines: list[str]) -> list[tuple[float, str, str]]:
    rows, inside = [], False
    for line in lines:
        if re.match(r"=+ slowest .*durations", line):
            inside = True
            continue
        if inside:
            m = re.match(r"([\d.]+)s (call|setup|teardown)\s+(\S+)", line)
            if not m:
                break
            rows.append((float(m.group(1)), m.group(2), m.group(3)))
    return rows[:SLOWEST]


def fmt_s(s: float) -> str:
    return f"{s:,.0f} s ({int(s // 60)} min {s % 60:02.0f} s)"


def report(repo: Path, res: dict, setup_fresh: bool) -> str:
    lines, marks, total = res["lines"], res["marks"], res["total_s"]
    commit = subprocess.run(["git", "-C", str(repo), "log", "-1", "--format=%h %s"],
                            capture_output=True, text=True).stdout.strip()[:90]
    dirty = subprocess.run(["git", "-C", str(repo), "status", "--short", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.split("\n")
    dirty = [d[3:] for d in dirty if d.strip()]
    workers = next((m.group(1) for line in lines
                    if (m := re.search(r"created: (\d+)/\d+ workers", line))), "none (no xdist)")
    summary = next((line.strip("= ") for line in reversed(lines)
                    if re.search(r"\d+ (passed|failed)", line)), "(no pytest summary)")
    pytest_s = total - marks["pytest"] if "pytest" in marks else None
    before_ctest = marks.get("ctest", marks.get("pytest", total))
    setup_s = res["setup_s"]
    load = res["load"] or [load1()]
    found = re.findall(r"--dist[ =]([a-z]+)\b(?!:)", (repo / "launch_scripts" / "test.sh").read_text())
    dist = f"--dist {found[-1]}" if found else "no --dist"
    out = [
        "# Test suite wall time",
        "",
        "Written by `benchmarks/bench_suite.py` (`bash launch_scripts/test.sh --durations=20`); "
        f"{datetime.now(UTC):%Y-%m-%d %H:%M} UTC.",
        "",
        f"- checkout: `{repo}` at `{commit}`"
        + (f" plus uncommitted {', '.join(f'`{d}`' for d in dirty)}" if dirty else ""),
        f"- machine: {os.cpu_count()} cores; "
        + ("fresh clone: setup configured and built the workspace" if setup_fresh
           else "setup found the workspace built"),
        f"- pytest workers: {workers} (`{dist}` in launch_scripts/test.sh)",
        f"- exit code {res['code']}; pytest: {summary}",
        "",
        "| phase | wall time |",
        "|---|---|",
        f"| `launch_scripts/setup.sh` (alone, first) | {fmt_s(setup_s)} |",
        f"| test.sh: setup check + ruff | {fmt_s(before_ctest)} |",
    ]
    if "ctest" in marks and "pytest" in marks:
        out.append(f"| test.sh: ctest | {fmt_s(marks['pytest'] - marks['ctest'])} |")
    if pytest_s is not None:
        out.append(f"| test.sh: pytest | {fmt_s(pytest_s)} |")
    out += [
        f"| **`bash launch_scripts/test.sh`, setup excluded** | **{fmt_s(total)}** |",
        f"| **setup included** (setup.sh + test.sh) | **{fmt_s(setup_s + total)}** |",
        "",
        f"CPU time of the suite's processes: {res['cpu_s']:,.0f} s "
        f"({res['cpu_s'] / (setup_s + total):.2f} cores on average).",
        "",
        f"Load (1-min average, /proc/loadavg every 5 s): mean {sum(load) / len(load):.2f}, "
        f"max {max(load):.2f}; at start {' '.join(res['load_start'])}, at end "
        f"{' '.join(res['load_end'])} (1, 5, 15 min). It includes whatever else ran on the "
        "machine.",
        "",
        f"## The {SLOWEST} slowest tests (setup, call or teardown phase)",
        "",
        "| s | phase | test |",
        "|---:|---|---|",
    ]
    out += [f"| {s:.1f} | {phase} | `{test}` |" for s, phase, test in slowest(lines)]
    failed = [line for line in lines if line.startswith(("FAILED ", "ERROR "))]
    if failed:
        out += ["", "## Failures", ""] + [f"- `{line}`" for line in failed]
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--repo", type=Path, default=HERE, help="checkout to test (default: this one)")
    p.add_argument("--clone", metavar="SOURCE",
                   help="first `git clone SOURCE REPO` (REPO must not exist; ../shared beside it)")
    p.add_argument("--workers", type=int, help="pytest workers (TPUAF_TEST_WORKERS)")
    p.add_argument("--out", type=Path, default=HERE / "benchmarks" / "results" / "suite.md")
    p.add_argument("pytest_args", nargs="*", help="after --: extra pytest arguments")
    args = p.parse_args(argv)
    repo = args.repo.resolve()
    if args.clone:
        if repo.exists():
            print(f"error: {repo} exists; --clone needs a new folder", file=sys.stderr)
            return 2
        subprocess.run(["git", "clone", "-q", args.clone, str(repo)], check=True)
    if not (repo / "launch_scripts" / "test.sh").is_file():
        print(f"error: {repo} has no launch_scripts/test.sh", file=sys.stderr)
        return 2
    setup_fresh = not (repo / "build" / "CMakeCache.txt").is_file()
    log = repo / "build" / "bench_suite.log" if (repo / "build").is_dir() else Path(
        "/tmp") / f"bench_suite_{os.getpid()}.log"
    res = run_suite(repo, args.workers, args.pytest_args, log)
    text = report(repo, res, setup_fresh)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    print(text)
    print(f"written {args.out}; full output {log}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
