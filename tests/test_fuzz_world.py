"""Fuzz (hypothesis, 1,000 cases each): tpuaf_stage world files. Whatever the document or the
bytes, load_world gives a WorldConfig (whose world then builds, or refuses a robot with
WorldError) or raises WorldError naming the file: never another exception."""

from __future__ import annotations

import os
import tempfile
from dataclasses import fields
from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tpuaf_stage.config import LaserModel, RobotModel, WorldConfig, WorldError, load_world

FUZZ_EXAMPLES = int(os.environ.get("TPUAF_FUZZ_EXAMPLES", "1000"))  # fewer while iterating
FUZZ = settings(max_examples=FUZZ_EXAMPLES, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

ROBOT_FIELDS = [f.name for f in fields(RobotModel)]
LASER_FIELDS = [f.name for f in fields(LaserModel)]
SCALARS = st.one_of(
    st.none(), st.booleans(), st.integers(-10**6, 10**6), st.integers(-2**70, 2**70),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
    st.sampled_from(["burger", "waffle_pi", "patrolling_sim", "lds01", "tank", "inf", "max",
                     "zero", "lab", "grid", "nowhere", "map.yaml", "../x"]),
)
VALUES = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=4)
                      | st.dictionaries(st.text(max_size=6), inner, max_size=3), max_leaves=8)
POSE = st.lists(st.one_of(st.floats(-5, 20), st.floats(allow_nan=True), st.text(max_size=3)),
                min_size=0, max_size=4)


def _section(names: list[str]):
    keys = st.sampled_from(["preset", *names]) | st.text(max_size=6)
    return st.dictionaries(keys, VALUES | st.floats(0, 3), max_size=5) | VALUES


WORLD = st.fixed_dictionaries({}, optional={
    "map": st.sampled_from(["map.yaml", "missing.yaml", "", "bad.yaml"]) | VALUES,
    "patrol_map": st.sampled_from(["lab", "grid", "nowhere", ""]) | VALUES,
    "seed": VALUES | st.integers(0, 2**40),
    "robot": _section(ROBOT_FIELDS),
    "laser": _section(LASER_FIELDS),
    "robots": st.lists(POSE, max_size=4) | st.integers(-2, 30) | VALUES,
}) | st.dictionaries(st.text(max_size=6), VALUES, max_size=3) | VALUES

MAP_YAML = ("image: map.pgm\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.196\n")


def _folder(root: Path) -> Path:
    (root / "map.yaml").write_text(MAP_YAML)
    (root / "bad.yaml").write_text("image: [\n")
    (root / "map.pgm").write_bytes(b"P5\n50 40\n255\n" + b"\xfe" * 2000)
    return root


def _check(path: Path) -> None:
    try:
        config = load_world(path)
    except WorldError as err:
        assert str(err).strip()  # (the CLI prints it on one line: tpuaf.cli.one_line)
        return
    assert isinstance(config, WorldConfig)
    if len(config.poses) <= 12:
        try:
            config.build()
        except WorldError:
            pass


@FUZZ
@given(doc=WORLD)
def test_fuzz_world_documents(doc):
    with tempfile.TemporaryDirectory() as tmp:
        root = _folder(Path(tmp))
        path = root / "world.yaml"
        path.write_text(yaml.safe_dump(doc, allow_unicode=True))
        _check(path)


TEMPLATE = ("patrol_map: lab\nseed: 3\nrobot: {preset: burger, radius: 0.105}\n"
            "laser: {preset: lds01, beams: 90}\nrobots: [[0.5, 0.5, 0.0], [2.5, 0.5, 3.14]]\n")


@FUZZ
@given(edits=st.lists(st.tuples(st.integers(0, len(TEMPLATE)), st.integers(0, 8),
                                st.text(max_size=6) | st.sampled_from(
                                    ["[", "]", "{", "}", ":", "-", "&a", "*a", "!!python/x",
                                     ".nan", ".inf", "1e400", "\t", "\n", "#", "'", "map: m"])),
                      min_size=1, max_size=5))
def test_fuzz_world_text(edits):
    text = TEMPLATE
    for at, length, tok in edits:
        text = text[:at] + tok + text[at + length:]
    with tempfile.TemporaryDirectory() as tmp:
        root = _folder(Path(tmp))
        path = root / "world.yaml"
        path.write_text(text)
        _check(path)
