"""The figures of the fault-free runs (PNG, headless): interval idleness box plots per strategy
and N (paper Fig. 4), metrics against N, and the acceleration ratio against N (paper Fig. 8).

Drawn with matplotlib's object-oriented API (no pyplot state). Each PNG carries the key of what
it shows (FIGURE_KEY: a hash of its maps' runs, samples and reference tours); a report written
again redraws only the figures whose key changed (a sweep that gained runs of one map redraws
that map's figures)."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from tpuaf.experiments.plots import new_figure
from tpuaf.experiments.report.common import FIGURES, _ratio, label
from tpuaf.experiments.report.data import Data
from tpuaf.experiments.report.tables import acceleration, acceleration_table

FIGURE_KEY = "tpuaf-figure-key"  # PNG text field
FIGURE_VERSION = "1"  # part of every key: a changed drawing redraws every figure


def _key(kind: str, data: Data, maps: list[str]) -> str:
    """Hash of what figure `kind` of `maps` shows: their runs, samples and reference tours."""
    h = hashlib.sha256(f"{FIGURE_VERSION} {kind} {maps!r}".encode())
    for r in data.rows:
        if r["map"] in maps:
            h.update(repr(sorted(r.items())).encode())
    for k in sorted(data.samples):
        if k[0] in maps:
            h.update(repr(k).encode())
            h.update(np.ascontiguousarray(data.samples[k], dtype=float).tobytes())
    for k in sorted(data.reference):
        if k[0] in maps:
            h.update(repr((k, sorted(data.reference[k].items()))).encode())
    return h.hexdigest()[:32]


def _drawn(path: Path, key: str) -> bool:
    """True if `path` is a PNG of this key already."""
    try:
        from PIL import Image

        with Image.open(path) as image:
            return getattr(image, "text", {}).get(FIGURE_KEY) == key
    except Exception:  # noqa: BLE001 - missing, unreadable or no PNG: draw it
        return False


def _save(fig: Any, path: Path, key: str) -> Path:
    fig.savefig(path, dpi=110, metadata={FIGURE_KEY: key})
    return path


def _colors(strategies: list[str]) -> dict[str, Any]:
    import matplotlib

    if len(strategies) <= 10:
        cmap = matplotlib.colormaps["tab10"]
        return {s: cmap(i % 10) for i, s in enumerate(strategies)}
    cmap = matplotlib.colormaps["tab20"]  # dark shades first, then the light ones
    return {s: cmap((2 * i) % 20 + (2 * i) // 20) for i, s in enumerate(strategies)}


def box_figure(data: Data, m: str, path: Path) -> Path | None:
    ns = data.robots(m)
    strategies = data.strategies(m)
    if not any((m, s, n) in data.samples for s in strategies for n in ns):
        return None
    key = _key("box", data, [m])
    if _drawn(path, key):
        return path
    width = 3.2 if len(strategies) <= 6 else 0.3 * len(strategies) + 0.6  # [in] per panel
    fig = new_figure(figsize=(width * len(ns) + 1, 4.6))
    axes = fig.subplots(1, len(ns), squeeze=False)
    colors = _colors(strategies)
    for ax, n in zip(axes[0], ns, strict=True):
        values = [data.samples.get((m, s, n), np.zeros(0)) for s in strategies]
        present = [(s, v) for s, v in zip(strategies, values, strict=True) if v.size]
        if not present:
            ax.set_visible(False)
            continue
        bp = ax.boxplot([v for _, v in present], showmeans=True, patch_artist=True,
                        meanprops={"marker": "x", "markeredgecolor": "black"},
                        medianprops={"color": "red"},
                        flierprops={"marker": "o", "markersize": 2, "alpha": 0.3})
        for patch, (s, _) in zip(bp["boxes"], present, strict=True):
            patch.set_facecolor(colors[s])
            patch.set_alpha(0.6)
        ax.set_xticks(range(1, len(present) + 1), [label(s) for s, _ in present],
                      rotation=90 if len(present) > 6 else 45, fontsize=7 if len(present) > 6 else 9)
        ref = data.reference.get((m, n))
        if ref:
            worst = min(ref["cyclic_worst_idleness_s"], ref["partition_worst_idleness_s"])
            ax.axhline(worst, color="black", ls="--", lw=1,
                       label="reference tour: worst idleness")
            ax.axhline(ref["cyclic_avg_idleness_visit_s"], color="black", ls=":", lw=1,
                       label="cyclic tour: mean interval")
        top = max(float(v.max()) for _, v in present)
        whisk = max(float(w.get_ydata().max()) for w in bp["whiskers"])
        if top > 10 * whisk:
            ax.set_yscale("log")
        ax.set_title(f"N = {n}")
        ax.grid(axis="y", alpha=0.3)
    axes[0][0].set_ylabel("interval idleness [s]")
    handles, labels = axes[0][0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(f"Interval idleness on {m} (all seeds pooled; x = mean, red = median)")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    return _save(fig, path, key)


def metrics_figure(data: Data, m: str, path: Path) -> Path:
    key = _key("metrics", data, [m])
    if _drawn(path, key):
        return path
    panels = [("idleness_avg_s", "I_avg [s]", None),
              ("idleness_max_s", "I_max [s]", "worst_idleness_s"),
              ("idleness_ins_mean_s", "I_ins [s]", "avg_idleness_time_s"),
              ("uncertainty_mean", "X (time mean)", None)]
    ns = data.robots(m)
    strategies = data.strategies(m)
    colors = _colors(strategies)
    fig = new_figure(figsize=(10, 7.5))
    axes = fig.subplots(2, 2)
    for ax, (col, name, ref_key) in zip(axes.flat, panels, strict=True):
        for k, s in enumerate(strategies):
            st = [data.stat(m, s, n, col) for n in ns]
            x = np.array(ns, dtype=float) * (1 + 0.012 * (k - len(strategies) / 2))
            ax.errorbar(x, [t.mean for t in st],
                        yerr=[t.ci if np.isfinite(t.ci) else 0 for t in st],
                        marker="o", ms=4, capsize=3, color=colors[s], label=label(s))
        if ref_key:
            refs = [data.reference.get((m, n)) for n in ns]
            if all(refs):
                best = [min(r[f"cyclic_{ref_key}"], r[f"partition_{ref_key}"]) for r in refs]
                ax.plot(ns, best, color="black", ls="--", lw=1.2,
                        label="reference tour (best of cyclic, partition)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(ns, [str(n) for n in ns])
        ax.minorticks_off()
        ax.set_xlabel("N")
        ax.set_ylabel(name)
        ax.grid(alpha=0.3, which="both")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(f"Metrics against team size on {m} (mean ± 95 % CI over seeds)")
    fig.tight_layout()
    return _save(fig, path, key)


def acceleration_figure(data: Data, path: Path) -> Path | None:
    maps = [m for m in data.maps() if 1 in data.robots(m) and len(data.robots(m)) > 1]
    if not maps:
        return None
    key = _key("acceleration", data, maps)
    if _drawn(path, key):
        return path
    fig = new_figure(figsize=(5.5 * len(maps), 4.2))
    axes = fig.subplots(1, len(maps), squeeze=False)
    for ax, m in zip(axes[0], maps, strict=True):
        ns = [n for n in data.robots(m) if n > 1]
        strategies = data.strategies(m)
        colors = _colors(strategies)
        for k, s in enumerate(strategies):
            st = [acceleration(data, m, s, n) for n in ns]
            x = np.array(ns, dtype=float) + 0.12 * (k - len(strategies) / 2)
            ax.errorbar(x, [t.mean for t in st], yerr=[t.ci if np.isfinite(t.ci) else 0 for t in st],
                        marker="o", ms=4, capsize=3, color=colors[s], label=label(s))
        refs = [data.reference.get((m, n)) for n in [1, *ns]]
        if all(refs):
            base = refs[0]["partition_avg_idleness_visit_s"]
            ax.plot(ns, [_ratio(base, n * r["partition_avg_idleness_visit_s"])
                         for n, r in zip(ns, refs[1:], strict=True)],
                    color="gray", ls=":", lw=1.2, label="partition tour")
        ax.axhline(1.0, color="black", ls="--", lw=1.2, label="linear (cyclic tour)")
        ax.set_xticks(ns)
        ax.set_xlabel("N")
        ax.set_ylabel("a(N) = I_avg(1) / (N I_avg(N))")
        ax.set_title(m)
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.suptitle("Acceleration ratio (mean ± 95 % CI over seeds)")
    fig.tight_layout()
    return _save(fig, path, key)


def figures_section(data: Data, figures: Path) -> list[str]:
    """## Figures; writes box_MAP.png, metrics_MAP.png and acceleration.png into `figures`."""
    md = ["## Figures", ""]
    for m in data.maps():
        p = box_figure(data, m, figures / f"box_{m}.png")
        if p:
            md += [f"### Interval idleness on {m} (paper Fig. 4)", "",
                   f"![interval idleness box plots, {m}]({FIGURES / p.name})", "",
                   "Dashed: the best reference tour's worst idleness; dotted: the cyclic "
                   "tour's mean interval between visits.", ""]
    for m in data.maps():
        p = metrics_figure(data, m, figures / f"metrics_{m}.png")
        md += [f"### Metrics against N on {m}", "",
               f"![metrics against N, {m}]({FIGURES / p.name})", ""]
    md += ["### Acceleration ratio (paper Fig. 8)", ""]
    p = acceleration_figure(data, figures / "acceleration.png")
    if p:
        md += [f"![acceleration ratio]({FIGURES / p.name})", "",
               "a(N) = I_avg(1) / (N I_avg(N)) per seed (same map, strategy and seed), > 1 is "
               "super-linear.", acceleration_table(data) or "", ""]
    else:
        md += ["Not available: the acceleration ratio needs N = 1 runs "
               "(`tpuaf compare --robots 1 4 8 12 ...`).", ""]
    return md
