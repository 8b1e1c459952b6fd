"""Fuzz (hypothesis, 1,000 cases each): the patrolling_sim reader and our map format. Whatever
the bytes, loading a map either gives a PatrolMap or raises MapError (one line naming the file):
never another exception, never a traceback."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tpuaf.maps import MapError, PatrolMap, load_map
from tpuaf.maps.builtin import make_lab
from tpuaf.maps.mapfile import save_map_folder

from .test_maps import GOOD_GRAPH, PS_YAML

FUZZ_EXAMPLES = int(os.environ.get("TPUAF_FUZZ_EXAMPLES", "1000"))  # fewer while iterating

FUZZ = settings(max_examples=FUZZ_EXAMPLES, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# Tokens a corrupted file might hold: numbers of every size and sign, words, specials.
ODD_TOKENS = st.sampled_from([
    "0", "1", "-1", "2", "3", "7", "40", "-40", "0.5", "-0.5", "1e12", "-1e12", "1e400", "nan",
    "inf", "-inf", "E", "W", "N", "S", "NE", "x", "", "#", "99999999999999999999", "0x10",
    "1_000", "\x00", "é", "[", "]", ":", "'", "\"",
]) | st.integers(-10**6, 10**6).map(str) | st.floats(allow_nan=True).map(repr)


def _mutations(tokens: list[str]):
    """Edit a token list: replace, delete, duplicate or insert tokens, or truncate."""
    index = st.integers(0, len(tokens) - 1)
    return st.lists(st.one_of(
        st.tuples(st.just("replace"), index, ODD_TOKENS),
        st.tuples(st.just("delete"), index, st.just("")),
        st.tuples(st.just("insert"), index, ODD_TOKENS),
        st.tuples(st.just("truncate"), index, st.just("")),
    ), min_size=1, max_size=6)


def _apply(tokens: list[str], edits) -> list[str]:
    out = list(tokens)
    for kind, i, tok in edits:
        i = min(i, max(len(out) - 1, 0))
        if kind == "replace" and out:
            out[i] = tok
        elif kind == "delete" and out:
            del out[i]
        elif kind == "insert":
            out.insert(i, tok)
        elif kind == "truncate":
            out = out[:i]
    return out


def _load(folder: Path):
    try:
        pm = load_map(folder)
    except MapError as err:
        text = str(err)
        assert text and "Traceback" not in text
        return None
    assert isinstance(pm, PatrolMap)
    assert np.isfinite(pm.positions).all()
    return pm


GRAPH_TOKENS = GOOD_GRAPH.split("\n")


@FUZZ
@given(edits=_mutations(GRAPH_TOKENS))
def test_fuzz_patrolling_sim_graph(edits):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "tiny"
        folder.mkdir()
        (folder / "tiny.graph").write_text("\n".join(_apply(GRAPH_TOKENS, edits)))
        (folder / "tiny.yaml").write_text(PS_YAML)
        pixels = np.full((20, 40), 254, dtype=np.uint8)
        (folder / "tiny.pgm").write_bytes(b"P5\n40 20\n255\n" + pixels.tobytes())
        _load(folder)


YAML_TOKENS = PS_YAML.replace(":", " : ").replace(",", " , ").split(" ")
POSES = "[InitialPoses]\ntiny_2 = [2.5, 2.5, 17.5, 2.5]\ntiny_1 = [12.5, 2.5]\n"


@FUZZ
@given(yaml_edits=_mutations(YAML_TOKENS), pose_edits=_mutations(POSES.split(" ")),
       header=st.binary(max_size=24), body=st.binary(max_size=64))
def test_fuzz_patrolling_sim_yaml_image_and_poses(yaml_edits, pose_edits, header, body):
    """The map_server YAML, the PGM image and initial_poses.txt, corrupted together."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "tiny"
        folder.mkdir()
        (folder / "tiny.graph").write_text(GOOD_GRAPH)
        (folder / "tiny.yaml").write_text(" ".join(_apply(YAML_TOKENS, yaml_edits)))
        pixels = np.full((20, 40), 254, dtype=np.uint8).tobytes()
        (folder / "tiny.pgm").write_bytes((b"P5\n40 20\n255\n" if not header else header)
                                          + (pixels if not body else body + pixels[len(body):]))
        (folder / "initial_poses.txt").write_text(" ".join(_apply(POSES.split(" "), pose_edits)))
        _load(folder)


def _our_folder(root: Path) -> tuple[Path, str, str]:
    folder = save_map_folder(make_lab(), root / "lab", occupancy_file=True)
    return folder, (folder / "map.yaml").read_text(), (folder / "graph.yaml").read_text()


_TEMPLATE_DIR = tempfile.TemporaryDirectory()
_FOLDER, MAP_YAML, GRAPH_YAML = _our_folder(Path(_TEMPLATE_DIR.name))
OUR_TOKENS = st.sampled_from([
    "0", "-1", "1e12", "-1e12", ".nan", ".inf", "-.inf", "null", "~", "true", "[]", "{}", "[1, 2]",
    "{a: 1}", "'x'", "&a", "*a", "!!binary", "---", "- ", ":", "#", "\t", "\n", "999999999999",
    "3.5", "abc", "id:", "x:", "edges:", "vertices:", "settings:", "initial_vertices: {2: [0, 0]}",
]) | st.floats(allow_nan=True).map(repr) | st.integers(-10**9, 10**9).map(str)


def _text_mutations(text: str):
    """Edit text at character positions: replace a span with a token, or cut the file."""
    pos = st.integers(0, len(text))
    return st.lists(st.tuples(pos, st.integers(0, 12), OUR_TOKENS), min_size=1, max_size=5)


def _apply_text(text: str, edits) -> str:
    for at, length, tok in edits:
        at = min(at, len(text))
        text = text[:at] + tok + text[at + length:]
    return text


@FUZZ
@given(map_edits=_text_mutations(MAP_YAML), graph_edits=_text_mutations(GRAPH_YAML),
       which=st.sampled_from(["map", "graph", "both"]))
def test_fuzz_our_map_format(map_edits, graph_edits, which):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "lab"
        folder.mkdir()
        for name in ("occupancy.yaml", "occupancy.pgm"):
            (folder / name).write_bytes((_FOLDER / name).read_bytes())
        (folder / "map.yaml").write_text(
            _apply_text(MAP_YAML, map_edits) if which != "graph" else MAP_YAML)
        (folder / "graph.yaml").write_text(
            _apply_text(GRAPH_YAML, graph_edits) if which != "map" else GRAPH_YAML)
        _load(folder)
