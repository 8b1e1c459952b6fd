"""`tpuaf render RUN_FOLDER`: an animation (GIF, or MP4 with ffmpeg) of the robots moving over
the map, vertices coloured by idleness or by X; and the folder's summary.png again."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tpuaf.cli.run import positive_float, positive_int
from tpuaf.errors import CliError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("folder", type=Path,
                   help="a results folder of `tpuaf run --out` or `tpuaf fleet --out` "
                        "(config.yaml, visits.csv, timeseries.csv; positions.csv if recorded)")
    p.add_argument("--out", type=Path, default=None,
                   help="animation file, .gif (Pillow) or .mp4 (needs ffmpeg) "
                        "(default: FOLDER/animation.gif)")
    frames = p.add_mutually_exclusive_group()
    frames.add_argument("--frames", type=positive_int, default=None,
                        help="number of frames, evenly spread over the run (default 200)")
    frames.add_argument("--step", type=positive_float, default=None, metavar="S",
                        help="simulated seconds between frames (instead of --frames)")
    p.add_argument("--fps", type=positive_float, default=10.0, help="frames per second")
    p.add_argument("--color", choices=["idleness", "uncertainty"], default="idleness",
                   help="vertex colour: idleness (time since the last visit) or X (ground truth)")
    p.add_argument("--dpi", type=positive_int, default=80, help="resolution (dots per inch)")
    p.add_argument("--summary", action="store_true",
                   help="also (re)write FOLDER/summary.png")


FRAME_BYTES_PER_DPI2 = 64  # [B / dpi^2]: a 6 x ~7 in frame, RGB while drawn, 1 B/px kept


def _span_s(folder: Path) -> float | None:
    """The run's length [s] from summary.json or config.yaml (None when neither says)."""
    import json

    from tpuaf.files import read_regular

    for name, key in (("summary.json", "duration_s"), ("config.yaml", "duration_s")):
        path = folder / name
        if not path.is_file():
            continue
        try:
            text = read_regular(path, max_bytes=16 << 20).decode("utf-8", "replace")
            doc = json.loads(text) if name.endswith(".json") else yaml_doc(path)
        except (OSError, ValueError):
            continue
        value = doc.get(key) if isinstance(doc, dict) else None
        if isinstance(value, int | float) and not isinstance(value, bool) and value > 0:
            return float(value)
    return None


MAX_JSON_BYTES = 64 << 20


def check_folder_files(folder: Path) -> None:
    """config.yaml and summary.json of the folder are data: regular files, bounded in size
    and nesting (the drawing code reads them as they are)."""
    import json

    from tpuaf.files import read_regular

    yaml_doc(folder / "config.yaml")
    path = folder / "summary.json"
    if path.exists() or path.is_symlink():
        text = read_regular(path, max_bytes=MAX_JSON_BYTES, error_class=CliError)
        try:
            json.loads(text)
        except RecursionError:
            raise CliError(f"{path}: nested too deeply") from None
        except ValueError as err:
            raise CliError(f"{path}: not JSON ({err})") from None


def yaml_doc(path: Path):
    from tpuaf_core import yamlfile

    return yamlfile.read_yaml_fast(path, CliError)


def check_request(folder: Path, args: argparse.Namespace) -> None:
    """Frames and their memory, before anything is drawn (cli/limits.py)."""
    from tpuaf.cli import limits

    frames = float(args.frames or 200)
    if args.step is not None:
        span = _span_s(folder)
        if span is not None:
            frames = span / args.step + 1
            limits.check_frames(frames, f"--step {args.step:g}",
                                f"--step {span / (limits.MAX_FRAMES - 1):.4g} or more fits "
                                f"this {span:g} s run")
    else:
        limits.check_frames(frames, f"--frames {args.frames}",
                            f"--frames {limits.MAX_FRAMES} or fewer")
    need = frames * FRAME_BYTES_PER_DPI2 * float(args.dpi) ** 2 + limits.BASE_BYTES
    budget = limits.budget_bytes()
    if need > budget:
        most = int(((budget - limits.BASE_BYTES) / (frames * FRAME_BYTES_PER_DPI2)) ** 0.5)
        raise CliError(f"--dpi {args.dpi}: {frames:,.0f} frames need about "
                       f"{limits.size_text(need)} of memory, more than the "
                       f"{limits.size_text(budget)} this machine can give; --dpi {most} or "
                       "less (or fewer frames) fits")


def run(args: argparse.Namespace) -> int:
    from tpuaf.experiments.animation import render
    from tpuaf.experiments.plots import summary_png
    from tpuaf.experiments.run_files import incomplete

    folder = args.folder
    if not folder.is_dir():
        raise CliError(f"{folder}: no such results folder")
    for name in ("config.yaml", "visits.csv", "timeseries.csv"):
        if not (folder / name).is_file():
            raise CliError(f"{folder}: no {name} (not a results folder of `tpuaf run --out`)")
    if args.out is not None and args.out.suffix.lower() not in (".gif", ".mp4"):
        raise CliError(f"--out {args.out}: the animation is a .gif or an .mp4 file")
    check_folder_files(folder)
    why = incomplete(folder)
    if why is not None:  # drawn from what was written, but never taken for a whole run
        print(f"tpuaf render: note: {folder} is incomplete: {why}", file=sys.stderr)
    check_request(folder, args)
    try:
        if args.summary:
            print(f"summary: {summary_png(folder)}")
        path, count = render(folder, args.out, frames=args.frames, step_s=args.step,
                             fps=args.fps, color=args.color, dpi=args.dpi)
    except (ValueError, KeyError, OSError) as err:
        raise CliError(f"{folder}: {err}") from None
    if path.resolve().parent == folder.resolve():  # `--overwrite` of the folder clears it
        from tpuaf.experiments.results_folder import record_written

        record_written(folder, path.name)
    print(f"animation: {path} ({count} frames at {args.fps:g} fps)")
    return 0
