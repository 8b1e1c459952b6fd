"""Issue 22 probe: hostile inputs, each `tpuaf` command a subprocess with a 30 s timeout.

Counts tracebacks, hangs (past 30 s), mixed results folders (two writers, a file outside the
folder written or deleted, a user's file deleted) and memory overruns (peak RSS of the child
above MEMORY_LIMIT_B, or an allocation error), per class of input; writes
benchmarks/results/hostile.md.

    .venv/bin/python benchmarks/probe_hostile.py [--quick] [--jobs 2] [--out FILE]

--quick runs every 10th case (a smoke test). `--team` runs only the hostile team traffic
classes of issue 33 against lock-step fleets (benchmarks/hostile_team.py), in their own section
of the results file. Children start with SIGINT, SIGTERM and SIGHUP
at their defaults (a background job inherits SIGINT ignored, `nohup` SIGHUP) and in their own
session; each gets RLIMIT_AS of 8 GB so
that a regression cannot take the machine's memory.
"""

from __future__ import annotations

import argparse
import concurrent.futures as futures
import contextlib
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
sys.path.insert(0, str(REPO))
from common import header, write  # noqa: E402

TPUAF = [str(REPO / ".venv" / "bin" / "tpuaf")]
PYTHON = str(REPO / ".venv" / "bin" / "python")
SHARED_MAPS = REPO.parent / "shared" / "maps" / "patrolling_sim"
TIMEOUT_S = 30.0
MEMORY_LIMIT_B = 3 << 30  # peak RSS above this is an overrun (the machine: 24 GB, 5 users)
ADDRESS_LIMIT_B = 8 << 30
STOP_WITHIN_S = 2.0  # a signal stops a command within this


@dataclass
class Case:
    klass: str
    name: str
    argv: list[str]
    setup: object = None  # callable(root) -> None, run before the command
    check: object = None  # callable(root, result) -> str | None: a mixed-folder problem
    signal_after_s: float | None = None
    signal_number: int = signal.SIGINT
    pair: bool = False  # run the command twice at once (concurrent writers)
    new: bool = False  # a class beyond the table


@dataclass
class Result:
    case: Case
    code: int | None = None
    stderr: str = ""
    wall_s: float = 0.0
    rss_b: int = 0
    codes: list = field(default_factory=list)
    problem: str | None = None
    stop_s: float | None = None

    @property
    def traceback(self) -> bool:
        return "Traceback (most recent call last)" in self.stderr

    @property
    def hang(self) -> bool:
        return self.code is None

    @property
    def memory(self) -> bool:
        text = self.stderr
        return self.rss_b > MEMORY_LIMIT_B or "MemoryError" in text or "bad_alloc" in text \
            or "Unable to allocate" in text


def _child_setup() -> None:
    """Own session; the stop signals at their defaults whatever the probe inherited (a
    background job ignores SIGINT, `nohup` SIGHUP: a child would inherit that)."""
    os.setsid()
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_LIMIT_B, ADDRESS_LIMIT_B))


def _spawn(argv: list[str], cwd: Path, stderr) -> subprocess.Popen:
    """The command with stderr to a file (a pipe would block a child that writes much)."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen(argv, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=stderr, preexec_fn=_child_setup, env=env)


def _wait(proc: subprocess.Popen, deadline: float) -> tuple[int | None, int]:
    """(exit code or None on timeout, peak RSS [B]) through wait4."""
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            proc.returncode = os.waitstatus_to_exitcode(status)
            return proc.returncode, usage.ru_maxrss * 1024
        if time.monotonic() > deadline:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            _, status, usage = os.wait4(proc.pid, 0)
            proc.returncode = os.waitstatus_to_exitcode(status)
            return None, usage.ru_maxrss * 1024
        time.sleep(0.02)


def run_case(case: Case, scratch: Path) -> Result:
    root = Path(tempfile.mkdtemp(dir=scratch, prefix="case-"))
    result = Result(case)
    try:
        if case.setup is not None:
            case.setup(root)
        argv = [a.replace("@", str(root) + "/", 1) if a.startswith("@") else a
                for a in case.argv]
        start = time.monotonic()
        logs = [tempfile.TemporaryFile(dir=scratch) for _ in range(2 if case.pair else 1)]
        procs = [_spawn(TPUAF + argv, root, log) for log in logs]
        if case.signal_after_s is not None:
            time.sleep(case.signal_after_s)
            sent = time.monotonic()
            for p in procs:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(p.pid, case.signal_number)
        errs = []
        for p, log in zip(procs, logs, strict=True):
            code, rss = _wait(p, start + TIMEOUT_S)
            result.codes.append(code)
            result.rss_b = max(result.rss_b, rss)
            log.seek(0)
            errs.append(log.read(1 << 20).decode("utf-8", "replace"))
            log.close()
        result.wall_s = time.monotonic() - start
        if case.signal_after_s is not None:
            result.stop_s = time.monotonic() - sent
        result.code = None if None in result.codes else result.codes[0]
        result.stderr = "\n".join(errs)
        if case.check is not None and not result.hang:
            result.problem = case.check(root, result)
    except Exception as err:  # noqa: BLE001 - a probe bug is reported, not fatal
        result.problem = f"probe error: {type(err).__name__}: {err}"
    finally:
        subprocess.run(["rm", "-rf", str(root)], check=False)
    return result


# ------------------------------------------------------------------------------ input makers


def write_file(rel: str, data: bytes | str):
    def setup(root: Path) -> None:
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data.encode() if isinstance(data, str) else data)
    return setup


def grid_folder(root: Path, name: str = "m") -> Path:
    """A copy of the built-in grid map as a map folder under root."""
    from tpuaf.paths import builtin_maps_dir

    src = builtin_maps_dir() / "grid"
    dst = root / name
    dst.mkdir(parents=True, exist_ok=True)
    for f in src.iterdir():
        if f.is_file():
            (dst / f.name).write_bytes(f.read_bytes())
    return dst


def edited_grid(file: str, edit):
    """A grid map folder at root/m whose `file` is edit(text_bytes) -> bytes."""
    def setup(root: Path) -> None:
        folder = grid_folder(root)
        path = folder / file
        path.write_bytes(edit(path.read_bytes()))
    return setup


def graph_file(text: str | bytes, yaml_image: bool = True):
    """A patrolling_sim map folder root/p (p.graph, p.yaml, p.pgm)."""
    def setup(root: Path) -> None:
        folder = root / "p"
        folder.mkdir()
        (folder / "p.graph").write_bytes(text.encode() if isinstance(text, str) else text)
        if yaml_image:
            (folder / "p.yaml").write_text("image: p.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n"
                                           "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n")
            (folder / "p.pgm").write_bytes(b"P5 40 40 255\n" + b"\xff" * 1600)
    return setup


GOOD_GRAPH = ("3\n40\n40\n0.1\n0\n0\n"
              "0\n5\n5\n1\n1\nE\n{c}\n"
              "1\n{x}\n5\n2\n0\nW\n{c}\n2\nE\n10\n"
              "2\n25\n5\n1\n1\nW\n10\n")


def graph_text(x: str = "15", c: str = "10", first: str = "3") -> str:
    return first + GOOD_GRAPH[1:].format(x=x, c=c)


def bag_setup(root: Path) -> None:
    code = textwrap.dedent(f"""
        import sys; sys.path.insert(0, {str(REPO)!r})
        from pathlib import Path
        from tests.test_bag import plain_bag
        plain_bag(Path({str(root)!r}) / "b", poses="odom")
    """)
    (root / "b").mkdir()
    subprocess.run([PYTHON, "-c", code], check=True, capture_output=True, timeout=120)


def make_fifo(rel: str):
    def setup(root: Path) -> None:
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        os.mkfifo(path)
    return setup


def symlink(rel: str, target: str):
    def setup(root: Path) -> None:
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.symlink_to(target.replace("@", str(root) + "/"))
    return setup


def both(*setups):
    def setup(root: Path) -> None:
        for s in setups:
            s(root)
    return setup


def finished_run(folder: str = "out"):
    """A finished results folder root/folder (a 5 s run)."""
    def setup(root: Path) -> None:
        subprocess.run(TPUAF + ["run", "--duration", "5", "--quiet", "--out", str(root / folder)],
                       check=True, capture_output=True, timeout=120, preexec_fn=_child_setup)
    return setup


# ------------------------------------------------------------------------------ checks


def one_writer(root: Path, result: Result) -> str | None:
    """Two writers of one new folder: exactly one ran, the other was refused; the folder holds
    one run (config and summary of the same seed), complete."""
    codes = sorted(result.codes)
    out = root / "out"
    if codes != [0, 2]:
        return f"exit codes {result.codes} (expected one 0 and one 2)"
    if "another tpuaf process" not in result.stderr:
        return "the refusal does not name the other writer"
    summary = json.loads((out / "summary.json").read_text())
    if not summary.get("complete"):
        return "summary not complete"
    return None


def victim_kept(root: Path, result: Result) -> str | None:
    victim = root / "victim.txt"
    if victim.read_text() != "keep\n":
        return "a file outside the folder was written"
    return None


def user_files_kept(root: Path, result: Result) -> str | None:
    for rel in ("out/plots/my_figure.png", "out/analysis/my_analysis.txt", "out/notes.md"):
        if not (root / rel).is_file():
            return f"{rel} was deleted"
    return victim_kept(root, result) if (root / "victim.txt").exists() else None


def marked_incomplete(root: Path, result: Result) -> str | None:
    """An interrupted command that wrote a folder leaves summary.json complete: false."""
    for path in root.rglob("summary.json"):
        try:
            if json.loads(path.read_text()).get("complete") is not False and result.code != 0:
                return f"{path.relative_to(root)} says complete after a signal"
        except ValueError:
            return f"{path.relative_to(root)} is not JSON"
    return None


# ------------------------------------------------------------------------------ the cases


def cases() -> list[Case]:  # noqa: C901 - one list of every class
    out: list[Case] = []

    def add(klass, name, argv, **kw):
        out.append(Case(klass, name, list(argv), **kw))

    run5 = ["run", "--duration", "5", "--quiet"]
    # unbounded resources
    for seeds in ("1000000000", "100000000", "10000000", "2147483647"):
        add("unbounded resources", f"compare --seeds {seeds}",
            ["compare", "--maps", "grid", "--strategies", "cr", "--robots", "1", "--duration",
             "60", "--seeds", seeds, "--out", "@sweep"])
    for strategy in ("tpuaf", "tpuaf_plus", "cr", "dtap", "msp", "gbs", "sebs", "cbls"):
        for n in ("1001", "10000", "2000000000"):
            add("unbounded resources", f"run --robots {n} --strategy {strategy}",
                run5 + ["--robots", n, "--strategy", strategy])
    for n in ("100000", "1001", "99999999999"):
        add("unbounded resources", f"analyze --robots {n}",
            ["analyze", "@b/run.bag", "--map", "grid", "--robots", n], setup=bag_setup)
    for step in ("1e-9", "1e-6", "0.001"):
        add("unbounded resources", f"render --step {step}",
            ["render", "@out", "--step", step], setup=finished_run())
    for dpi in ("100000", "5000"):
        add("unbounded resources", f"render --dpi {dpi}",
            ["render", "@out", "--dpi", dpi, "--frames", "100"], setup=finished_run())
    for w, h in ((30000, 30000), (100000, 100000), (2**31 - 1, 2**31 - 1), (1, 2**31 - 1)):
        ihdr = (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + w.to_bytes(4, "big")
                + h.to_bytes(4, "big") + b"\x08\x00\x00\x00\x00" + b"\x00" * 4)
        add("unbounded resources", f"PNG map image {w}x{h}",
            ["maps", "@p"], setup=both(
                graph_file(graph_text(), yaml_image=False),
                write_file("p/p.yaml", "image: p.png\nresolution: 0.1\norigin: [0, 0, 0]\n"),
                write_file("p/p.png", ihdr)))
        add("unbounded resources", f"PGM map image {w}x{h}",
            ["maps", "@p"], setup=both(
                graph_file(graph_text(), yaml_image=False),
                write_file("p/p.yaml", "image: p.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n"),
                write_file("p/p.pgm", f"P5 {w} {h} 255\n".encode() + b"\xff" * 64)))
    for workers in ("100000", "1000"):
        add("unbounded resources", f"compare --workers {workers}",
            ["compare", "--workers", workers, "--seeds", "1", "--out", "@sweep"])
    # long runs and signals
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        for after in (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 4.0):
            add("signals at the edges", f"run --duration 1e12, {sig.name} at {after} s",
                ["run", "--duration", "1e12", "--quiet", "--out", "@out"],
                signal_after_s=after, signal_number=sig, check=marked_incomplete)
        for after in (1.0, 3.0):
            add("long runs", f"run 1e7 s --out, {sig.name} at {after} s",
                ["run", "--map", "grid", "--robots", "2", "--duration", "1e7", "--quiet",
                 "--out", "@out"], signal_after_s=after, signal_number=sig,
                check=marked_incomplete)
        for after in (0.1, 1.5, 3.0):
            add("signals at the edges", f"analyze, {sig.name} at {after} s",
                ["analyze", "@b/run.bag", "--map", "grid", "--out", "@an"], setup=bag_setup,
                signal_after_s=after, signal_number=sig, check=marked_incomplete)
        for cmd in (["maps"], ["report", "@nothing"], ["compare", "--seeds", "1", "--out",
                                                       "@sweep", "--duration", "60"]):
            add("signals at the edges", f"{cmd[0]}, {sig.name} at 0.3 s", cmd,
                signal_after_s=0.3, signal_number=sig)
    # concurrent writers
    for k in range(5):
        add("concurrent writers", f"two runs, one new --out (try {k + 1})",
            run5 + ["--out", "@out", "--seed", str(k)], pair=True, check=one_writer)
    add("concurrent writers", "two analyses, one --out",
        ["analyze", "@b/run.bag", "--map", "grid", "--out", "@out"], setup=bag_setup, pair=True,
        check=one_writer)
    # links and special files
    for name in ("visits.csv", "summary.json", "timeseries.csv", "config.yaml", "info.csv",
                 ".tpuaf-files", ".tpuaf-lock", "summary.png"):
        def setup(root, name=name):
            finished_run()(root)
            (root / "victim.txt").write_text("keep\n")
            (root / "out" / name).unlink(missing_ok=True)
            (root / "out" / name).symlink_to(root / "victim.txt")
        add("links and special files", f"{name} is a link out, --overwrite",
            run5 + ["--out", "@out", "--overwrite"], setup=setup, check=victim_kept)
    for target in ("/dev/zero", "/dev/urandom", "@loop", "@fifo"):
        special = both(make_fifo("fifo"), symlink("loop", "@loop"))
        add("links and special files", f".graph -> {target}", ["maps", "@p/p.graph"],
            setup=both(special, graph_file(graph_text()),
                       lambda root, t=target: ((root / "p/p.graph").unlink(),
                                               (root / "p/p.graph").symlink_to(
                                                   t.replace("@", str(root) + "/")))))
        add("links and special files", f"map.yaml -> {target}", ["maps", "@m"],
            setup=both(special, lambda root, t=target: (grid_folder(root), (
                root / "m/map.yaml").unlink(), (root / "m/map.yaml").symlink_to(
                t.replace("@", str(root) + "/")))))
        add("links and special files", f"graph.yaml -> {target}", ["run", "--map", "@m",
                                                                   "--duration", "5"],
            setup=both(special, lambda root, t=target: (grid_folder(root), (
                root / "m/graph.yaml").unlink(), (root / "m/graph.yaml").symlink_to(
                t.replace("@", str(root) + "/")))))
        add("links and special files", f"bag -> {target}",
            ["analyze", target if not target.startswith("@") else target, "--map", "grid"],
            setup=special)
        add("links and special files", f"config.yaml beside a bag -> {target}",
            ["analyze", "@b/run.bag"], setup=both(special, bag_setup, lambda root, t=target: (
                root / "b/config.yaml").symlink_to(t.replace("@", str(root) + "/"))))
    add("links and special files", "the bag is a folder", ["analyze", "@b", "--map", "grid"],
        setup=bag_setup)
    add("links and special files", "--out is a FIFO", run5 + ["--out", "@fifo"],
        setup=make_fifo("fifo"))
    add("links and special files", "--out is a link loop", run5 + ["--out", "@loop"],
        setup=symlink("loop", "@loop"))
    add("links and special files", "--out is /dev/null", run5 + ["--out", "/dev/null"])
    add("links and special files", "compare --out is a link loop",
        ["compare", "--seeds", "1", "--out", "@loop"], setup=symlink("loop", "@loop"))
    add("links and special files", "render of a FIFO folder", ["render", "@fifo"],
        setup=make_fifo("fifo"))
    # wrong pairing
    maps = ["lab"] + [str(SHARED_MAPS / m) for m in ("cumberland", "example", "1r5",
                                                     "DIAG_labs", "ctcv")
                      if (SHARED_MAPS / m).is_dir()]
    for m in maps:
        def wrong(root, result, m=m):
            if result.code == 0:
                return f"a grid bag analysed with {Path(m).name}: accepted without a word"
            return None
        add("wrong pairing", f"grid bag, --map {Path(m).name}",
            ["analyze", "@b/run.bag", "--map", m, "--out", "@an"], setup=bag_setup, check=wrong)
    add("wrong pairing", "grid bag, --robots 1", ["analyze", "@b/run.bag", "--map", "grid",
                                                  "--robots", "1"], setup=bag_setup)

    def changed_map(root: Path) -> None:
        folder = grid_folder(root)
        subprocess.run(TPUAF + ["compare", "--maps", str(folder), "--strategies", "cr",
                                "--robots", "1", "--seeds", "1", "--duration", "30",
                                "--out", str(root / "sweep"), "--quiet", "--workers", "1"],
                       check=True, capture_output=True, timeout=180, preexec_fn=_child_setup)
        graph = folder / "graph.yaml"
        graph.write_text(graph.read_text().replace("x: 1.425, y: 1.425", "x: 1.6, y: 1.425", 1))

    def refused_resume(root, result):
        if result.code != 2 or "changed since" not in result.stderr:
            return f"resumed over a changed map (exit {result.code})"
        return None
    add("wrong pairing", "resume a sweep after its map changed",
        ["compare", "--maps", "@m", "--strategies", "cr", "--robots", "1", "--seeds", "2",
         "--duration", "30", "--out", "@sweep", "--quiet", "--workers", "1"],
        setup=changed_map, check=refused_resume)
    # --overwrite
    def user_setup(root: Path, victim: bool = False) -> None:
        finished_run()(root)
        for rel in ("out/plots/my_figure.png", "out/analysis/my_analysis.txt", "out/notes.md"):
            (root / rel).parent.mkdir(exist_ok=True)
            (root / rel).write_text("mine\n")
        if victim:
            (root / "victim.txt").write_text("keep\n")
            (root / "out" / ".tpuaf-files").write_text("../victim.txt\nplots/\nanalysis/\n"
                                                       f"{root}/victim.txt\n")
    add("--overwrite", "user's plots/ and analysis/ files", run5 + ["--out", "@out",
                                                                    "--overwrite"],
        setup=user_setup, check=user_files_kept)
    add("--overwrite", "a manifest naming ../ and absolute paths",
        run5 + ["--out", "@out", "--overwrite"], setup=lambda r: user_setup(r, True),
        check=user_files_kept)
    add("--overwrite", "analyze --overwrite over a run folder",
        ["analyze", "@b/run.bag", "--map", "grid", "--out", "@out", "--overwrite"],
        setup=both(bag_setup, user_setup), check=user_files_kept)
    # encodings and depth
    for pos, bad in ((0, b"\xff"), (10, b"\xc3\x28"), (40, b"\x80\x80"), (-2, b"\xfe")):
        for file in ("map.yaml", "graph.yaml"):
            add("encodings and depth", f"{file}: bytes {bad!r} at {pos}", ["maps", "@m"],
                setup=edited_grid(file, lambda t, p=pos, b=bad: t[:p] + b + t[p:]))
        add("encodings and depth", f".graph: bytes {bad!r} at {pos}", ["maps", "@p"],
            setup=graph_file(graph_text().encode()[:max(pos, 0)] + bad
                             + graph_text().encode()[max(pos, 0):]))
    for depth in (65, 100, 1000, 5000, 30000, 200000):
        nested = "[" * depth + "]" * depth
        add("encodings and depth", f"graph.yaml nested {depth} deep (flow)", ["maps", "@m"],
            setup=edited_grid("graph.yaml", lambda t, n=nested: b"edges: " + n.encode()
                              + b"\n" + t.split(b"edges:")[0]))
        block = "".join(" " * k + "- \n" for k in range(0, min(depth, 3000) * 2, 2))
        add("encodings and depth", f"map.yaml nested {depth} deep (block)", ["maps", "@m"],
            setup=edited_grid("map.yaml", lambda t, b=block: t + b"description:\n" + b.encode()))
    for vid in ("2147483648", str(2**63), str(2**64 + 1), "-1", "-9223372036854775809",
                "1.5", "1e3", "abc", "[1]", "{a: 1}", "true", "null", "0x10", "0o17"):
        add("encodings and depth", f"vertex id {vid}", ["maps", "@m"],
            setup=edited_grid("graph.yaml", lambda t, v=vid: t.replace(b"{id: 0,",
                                                                       f"{{id: {v},".encode(), 1)))
    for cost in ("1e300", "1e9", "1e7", ".inf", ".nan", "-1", "0", "1e-300", "abc", "[1]"):
        add("encodings and depth", f"edge length {cost}", ["run", "--map", "@m", "--duration",
                                                           "5", "--quiet"],
            setup=edited_grid("graph.yaml", lambda t, c=cost: t.replace(
                b"edges:\n", b"edges:\n", 1).replace(b"- [0, 1]", f"- [0, 1, {c}]".encode(), 1)))
    for coord in ("1e300", "1e12", "-1e7", ".inf", "1e6", "999999"):
        add("encodings and depth", f"vertex x {coord}", ["maps", "@m"],
            setup=edited_grid("graph.yaml", lambda t, c=coord: t.replace(
                b"x: 1.425", f"x: {c}".encode(), 1)))
    add("encodings and depth", "a list as a mapping key (map.yaml)", ["maps", "@m"],
        setup=edited_grid("map.yaml", lambda t: t + b"? [a, b]\n: 1\n"))
    add("encodings and depth", "a list as a mapping key (graph.yaml)", ["maps", "@m"],
        setup=edited_grid("graph.yaml", lambda t: b"{[1]: 2}: 3\n" + t))
    # numbers
    for tok in ("2_39", "\uff12\uff13\uff19", "\u0663", "+5", "5.", "1e3", "0x10", "\u00b2",
                "99999999999999999999", "-0", "nan", "inf", "1_0.5", "\u0bea"):
        add("numbers", f".graph x token {tok!r}", ["maps", "@p"],
            setup=graph_file(graph_text(x=tok)))
        add("numbers", f".graph vertex count {tok!r}", ["maps", "@p"],
            setup=graph_file(graph_text(first=tok)))
    for cost in ("1e9", "1e12", "1e300", "1e-300", "5e6"):
        for strategy in ("tpuaf_plus", "cgg", "tpuaf"):
            add("numbers", f".graph cost {cost}, {strategy}",
                ["run", "--map", "@p", "--strategy", strategy, "--duration", "60", "--quiet",
                 "--robots", "2"], setup=graph_file(graph_text(c=cost)))
    for width in ("1e6", "1e7", "1e300", "'1e6'", "1.0e+6", "1E6", "-1e6", "0"):
        add("numbers", f"corridor_width: {width}", ["maps", "@m"],
            setup=edited_grid("map.yaml", lambda t, w=width: t + f"corridor_width: {w}\n"
                              .encode() if b"corridor_width" not in t else t.replace(
                                  b"corridor_width:", f"corridor_width: {w} #".encode(), 1)))
    # smaller
    for address in ("notaurl", "tcp://", "tcp://host:99999", ":", "tcp://[::1", "x" * 5000,
                    "tcp://127.0.0.1:0", "http://127.0.0.1:8786/x"):
        add("smaller", f"--scheduler {address[:20]}", ["compare", "--scheduler", address,
                                                       "--seeds", "1", "--out", "@sweep"])
    for robot in ("tank", "", "x" * 100000):
        add("smaller", f"compare --robot {robot[:10]!r}", ["compare", "--robot", robot,
                                                           "--seeds", "1", "--out", "@sweep"])
    big = "x" * 120_000  # the kernel's limit of one argument is 128 kB
    for argv in (run5 + ["--strategy", big], run5 + ["--map", big], run5 + ["--param",
                                                                            f"g1={big}"],
                 run5 + ["--param", f"{big}=1"], ["maps", big], ["report", big],
                 ["compare", "--maps", big, "--seeds", "1", "--out", "@sweep"]):
        def short(root, result):
            if any(len(line) > 1000 for line in result.stderr.splitlines()):
                return "a message line over 1000 characters"
            return None
        add("smaller", f"a 120 kB token: {' '.join(argv[:2])} {argv[-2][:20]}", argv,
            check=short)
    for params in (["weight_min=3", "weight_max=1"], ["weight_min=-1"], ["weight_max=1e400"]):
        add("smaller", f"cbls --param {' '.join(params)}",
            run5 + ["--strategy", "cbls"] + sum((["--param", p] for p in params), []))
    # classes added here
    bomb = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{chr(98 + k)}: &{chr(98 + k)} [*{chr(97 + k)}, *{chr(97 + k)}, *{chr(97 + k)}, "
        f"*{chr(97 + k)}, *{chr(97 + k)}, *{chr(97 + k)}, *{chr(97 + k)}, *{chr(97 + k)}]\n"
        for k in range(9))
    for file in ("map.yaml", "graph.yaml"):
        add("YAML alias bombs", f"{file}: 9 levels of 8 aliases", ["maps", "@m"], new=True,
            setup=edited_grid(file, lambda t, b=bomb: b.encode() + t))
        add("YAML alias bombs", f"{file}: alias bomb as settings", ["maps", "@m"], new=True,
            setup=edited_grid(file, lambda t, b=bomb: t + b.replace("a: &a", "settings: &a")
                              .encode()))
    for size in (70 << 20, 200 << 20):
        add("huge files", f"graph.yaml of {size >> 20} MB", ["maps", "@m"], new=True,
            setup=edited_grid("graph.yaml", lambda t, s=size: t + b"#" * s + b"\n"))
        add("huge files", f".graph of {size >> 20} MB", ["maps", "@p"], new=True,
            setup=graph_file(graph_text() + " " * size))
    add("huge files", "a sparse 1 TB map.yaml", ["maps", "@m"], new=True,
        setup=lambda root: (grid_folder(root), os.truncate(root / "m/map.yaml", 1 << 40)))
    for name in ("map.yaml", "graph.yaml"):
        add("empty and odd files", f"empty {name}", ["maps", "@m"], new=True,
            setup=edited_grid(name, lambda t: b""))
        add("empty and odd files", f"{name} is a folder", ["maps", "@m"], new=True,
            setup=lambda root, n=name: (grid_folder(root), (root / "m" / n).unlink(),
                                        (root / "m" / n).mkdir()))
        add("empty and odd files", f"{name} of NUL bytes", ["maps", "@m"], new=True,
            setup=edited_grid(name, lambda t: b"\0" * 4096))
        add("empty and odd files", f"{name} unreadable (mode 000)", ["maps", "@m"], new=True,
            setup=lambda root, n=name: (grid_folder(root), os.chmod(root / "m" / n, 0)))
    for garbage in (b"", b"#ROSBAG V2.0\n", b"#ROSBAG V2.0\n" + b"\xff" * 5000, os.urandom(4096)):
        add("empty and odd files", f"bag of {len(garbage)} odd bytes",
            ["analyze", "@x.bag", "--map", "grid"], new=True, setup=write_file("x.bag", garbage))
    for path in ("a" * 5000, "/" + "d/" * 3000, "\x01\x02name", "-", "--"):
        add("odd paths", f"--out {path[:12]!r}", run5 + ["--out", path], new=True)
        add("odd paths", f"--map {path[:12]!r}", run5 + ["--map", path], new=True)
    for cfg in ("duration_s: 1e300\n", "duration_s: -5\n", "[" * 5000, "duration_s: .nan\n",
                "robots: 1e9\n", "a: " + "x" * 100 + "\n"):
        def setup(root, cfg=cfg):
            finished_run()(root)
            (root / "out" / "config.yaml").write_text(cfg)
        add("results folders as input", f"render, config.yaml {cfg[:14]!r}",
            ["render", "@out", "--step", "1"], setup=setup, new=True)
    return out


# ------------------------------------------------------------------------------ report


def report(results: list[Result], wall_s: float) -> str:
    classes: dict[str, list[Result]] = {}
    for r in results:
        classes.setdefault(r.case.klass, []).append(r)
    totals = {"cases": len(results), "tracebacks": 0, "hangs": 0, "mixed": 0, "memory": 0,
              "slow stops": 0}
    lines = [header("Hostile inputs (issue 22): `benchmarks/probe_hostile.py`"),
             f"Each case a `tpuaf` subprocess (own session, stop signals at their defaults, RLIMIT_AS "
             f"{ADDRESS_LIMIT_B >> 30} GB), {TIMEOUT_S:g} s timeout; memory overrun = peak "
             f"RSS above {MEMORY_LIMIT_B >> 30} GB or an allocation error; mixed = a results "
             f"folder check failed (two writers, a file outside written, a user's file "
             f"deleted, a wrong pairing accepted); slow stop = a signal that did not end the "
             f"command within {STOP_WITHIN_S:g} s. Load average at the start: "
             f"{os.getloadavg()[0]:.1f} (2 cores shared with other sessions). Wall time "
             f"{wall_s:.0f} s.\n",
             "| class | cases | tracebacks | hangs > 30 s | mixed folders | memory overruns | "
             "slow stops | exit codes |", "|---|---|---|---|---|---|---|---|"]
    for klass, rs in classes.items():
        tb = sum(r.traceback for r in rs)
        hang = sum(r.hang for r in rs)
        mixed = sum(bool(r.problem) for r in rs)
        mem = sum(r.memory for r in rs)
        slow = sum(1 for r in rs if r.stop_s is not None and r.stop_s > STOP_WITHIN_S)
        codes: dict = {}
        for r in rs:
            codes[r.code] = codes.get(r.code, 0) + 1
        for key, v in (("tracebacks", tb), ("hangs", hang), ("mixed", mixed), ("memory", mem),
                       ("slow stops", slow)):
            totals[key] += v
        added = " (added)" if any(r.case.new for r in rs) else ""
        lines.append(f"| {klass}{added} | {len(rs)} | {tb} | {hang} | {mixed} | {mem} | {slow} "
                     f"| {', '.join(f'{k}: {v}' for k, v in sorted(codes.items(), key=str))} |")
    lines.append(f"| **all** | **{totals['cases']}** | **{totals['tracebacks']}** | "
                 f"**{totals['hangs']}** | **{totals['mixed']}** | **{totals['memory']}** | "
                 f"**{totals['slow stops']}** | |")
    stops = sorted(r.stop_s for r in results if r.stop_s is not None)
    if stops:
        lines.append(f"\nSignals: {len(stops)} cases, time from the signal to the exit: median "
                     f"{stops[len(stops) // 2]:.2f} s, max {stops[-1]:.2f} s.")
    rss = sorted(r.rss_b for r in results)
    lines.append(f"Peak RSS of a case: median {rss[len(rss) // 2] / 1e6:.0f} MB, max "
                 f"{rss[-1] / 1e6:.0f} MB.")
    bad = [r for r in results if r.traceback or r.hang or r.problem or r.memory
           or (r.stop_s is not None and r.stop_s > STOP_WITHIN_S)]
    if bad:
        lines.append("\n## Failures\n")
        for r in bad:
            last = [x for x in r.stderr.splitlines() if x.strip()][-1:] or [""]
            lines.append(f"- {r.case.klass} / {r.case.name[:80]}: exit {r.code}, "
                         f"{r.problem or ''} {'traceback ' if r.traceback else ''}"
                         f"stop {r.stop_s if r.stop_s is None else round(r.stop_s, 2)} s; "
                         f"`{last[0][:200]}`")
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="every 10th case")
    parser.add_argument("--jobs", type=int, default=2, help="cases at once")
    parser.add_argument("--only", default=None, help="only classes containing this text")
    parser.add_argument("--out", default="hostile.md", help="results file (benchmarks/results)")
    parser.add_argument("--team", action="store_true", help="only the hostile team traffic "
                        "against a lock-step fleet (issue 33; its section of the results file)")
    args = parser.parse_args()
    if args.team:
        import hostile_team

        with tempfile.TemporaryDirectory(prefix="probe-team-") as tmp:
            hostile_team.main(REPO / "benchmarks" / "results" / args.out, Path(tmp))
        return 0
    todo = cases()
    if args.only:
        todo = [c for c in todo if args.only in c.klass]
    if args.quick:
        todo = todo[::10]
    print(f"{len(todo)} cases, {args.jobs} at a time", file=sys.stderr)
    scratch = Path(tempfile.mkdtemp(prefix="probe-hostile-"))
    start = time.monotonic()
    results = []
    try:
        with futures.ThreadPoolExecutor(args.jobs) as pool:
            for k, r in enumerate(pool.map(lambda c: run_case(c, scratch), todo)):
                flag = ("TRACEBACK " if r.traceback else "") + ("HANG " if r.hang else "") + \
                    (f"MIXED({r.problem}) " if r.problem else "") + ("MEMORY " if r.memory else "")
                print(f"[{k + 1}/{len(todo)}] {r.case.klass} / {r.case.name[:80]}: exit {r.code} "
                      f"{r.wall_s:.1f} s {flag}", file=sys.stderr)
                results.append(r)
    finally:
        subprocess.run(["rm", "-rf", str(scratch)], check=False)
    text = report(results, time.monotonic() - start)
    previous = REPO / "benchmarks" / "results" / args.out
    mark = "<!-- team traffic: benchmarks/hostile_team.py -->"  # (its section is kept)
    if previous.is_file() and mark in previous.read_text():
        text += "\n" + mark + previous.read_text().split(mark, 1)[1]
    write(args.out, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
