"""Issue 22, results folders: one writer per folder (a flock), no write through a link, and
`--overwrite` removes only what the folder's manifest lists."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

from tpuaf.experiments.results_folder import LOCK_FILE, MANIFEST, prepare_out_dir, unlock_folder
from tpuaf.files import _temp_path, atomic_write_text

from tests.test_bad_input import assert_one_line_error, cli

PYTHON = sys.executable


def hold_lock(folder) -> subprocess.Popen:
    """A second process that takes the folder's writer lock and keeps it until killed."""
    code = textwrap.dedent(f"""
        import sys, time
        from tpuaf.experiments.results_folder import prepare_out_dir
        prepare_out_dir({str(folder)!r})
        print("locked", flush=True)
        time.sleep(60)
    """)
    proc = subprocess.Popen([PYTHON, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "locked"
    return proc


def test_second_writer_of_a_new_folder_is_refused(capsys, tmp_path):
    """Two runs started together with one new --out both wrote into it (mixed config and
    summary, 'complete': true)."""
    out = tmp_path / "run"
    holder = hold_lock(out)
    try:
        code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--out", str(out))
        assert_one_line_error(code, err, "another tpuaf process", f"pid {holder.pid}")
        assert not (out / "config.yaml").exists()
        code, _, err = cli(capsys, "compare", "--maps", "grid", "--strategies", "cr",
                           "--robots", "1", "--seeds", "1", "--duration", "5", "--quiet",
                           "--out", str(out))
        assert_one_line_error(code, err, "another tpuaf process")
    finally:
        holder.kill()
        holder.wait()
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--out", str(out))
    assert code == 0, err  # the lock died with its process
    unlock_folder(out)


def test_lock_is_held_for_the_process_life(tmp_path):
    out = prepare_out_dir(tmp_path / "run")
    assert (out / LOCK_FILE).read_text().strip() == str(os.getpid())
    assert prepare_out_dir(out) == out  # the same process: no-op
    unlock_folder(out)


def test_overwrite_never_writes_through_a_link(capsys, tmp_path):
    """visits.csv replaced by a link to a file outside, then --overwrite: the outside file was
    overwritten."""
    out = tmp_path / "run"
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--out", str(out))
    assert code == 0, err
    unlock_folder(out)
    victim = tmp_path / "victim.txt"
    victim.write_text("keep\n")
    for name in ("visits.csv", "summary.json", "timeseries.csv"):
        (out / name).unlink()
        (out / name).symlink_to(victim)
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--out", str(out),
                       "--overwrite")
    assert code == 0, err
    unlock_folder(out)
    assert victim.read_text() == "keep\n"
    for name in ("visits.csv", "summary.json", "timeseries.csv"):
        assert not (out / name).is_symlink()
    assert json.loads((out / "summary.json").read_text())["complete"] is True


def test_atomic_write_ignores_a_planted_temporary_link(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep\n")
    target = tmp_path / "summary.json"
    _temp_path(target).symlink_to(victim)
    atomic_write_text(target, "new\n")
    assert victim.read_text() == "keep\n"
    assert target.read_text() == "new\n"


def test_overwrite_keeps_the_users_files(capsys, tmp_path):
    """plots/my_figure.png and analysis/my_analysis.txt in a results folder were deleted."""
    out = tmp_path / "run"
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--out", str(out))
    assert code == 0, err
    unlock_folder(out)
    for rel in ("plots/my_figure.png", "analysis/my_analysis.txt", "notes.md"):
        (out / rel).parent.mkdir(exist_ok=True)
        (out / rel).write_text("mine\n")
    code, _, err = cli(capsys, "run", "--duration", "5", "--quiet", "--out", str(out),
                       "--overwrite")
    assert code == 0, err
    unlock_folder(out)
    for rel in ("plots/my_figure.png", "analysis/my_analysis.txt", "notes.md"):
        assert (out / rel).read_text() == "mine\n", rel
    assert "visits.csv" in (out / MANIFEST).read_text().split()


def test_manifest_folder_entries_and_escapes(tmp_path):
    """'name/' removes a folder tpuaf created whole; '../x', 'a/b' and links are never
    followed."""
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "keep.txt").write_text("keep\n")
    out = tmp_path / "run"
    out.mkdir()
    (out / "ros_home").mkdir()
    (out / "ros_home" / "log.txt").write_text("x")
    (out / "linked").symlink_to(outside)
    (out / "config.yaml").write_text("a: 1\n")
    (out / MANIFEST).write_text("ros_home/\nlinked/\n../outside/\noutside/keep.txt\nconfig.yaml\n")
    prepare_out_dir(out, overwrite=True)
    unlock_folder(out)
    assert not (out / "ros_home").exists()
    assert not (out / "linked").is_symlink()  # the link itself is removed...
    assert (outside / "keep.txt").read_text() == "keep\n"  # ...never what it points to
    assert not (out / "config.yaml").exists()
