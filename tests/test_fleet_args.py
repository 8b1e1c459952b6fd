"""Issue 33 item 7: numbers in `tpuaf fleet`'s arguments are parsed once, the same way: the
same run, however it is written, gives the same roslaunch args (--prepare-only)."""

from __future__ import annotations

import subprocess
from pathlib import Path

TPUAF = str(Path(__file__).resolve().parents[1] / ".venv" / "bin" / "tpuaf")


def launch_args(tmp_path: Path, name: str, duration: str, seed: str) -> list[str]:
    out = tmp_path / name
    proc = subprocess.run([TPUAF, "fleet", "--map", "grid", "--robots", "3", "--duration",
                           duration, "--seed", seed, "--out", str(out), "--prepare-only"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    line = proc.stdout.strip().splitlines()[-1].replace(str(out), "OUT")
    return line.split()


def test_the_same_numbers_written_differently_give_the_same_run(tmp_path):
    a = launch_args(tmp_path, "a", "60.0", "7")
    assert "duration:=60.0" in a and "seed:=7" in a
    for k, (duration, seed) in enumerate([(" 60", "7"), ("60", "07"), ("6e1", " 7")]):
        assert launch_args(tmp_path, f"b{k}", duration, seed) == a, (duration, seed)
