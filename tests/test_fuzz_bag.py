"""Fuzz (hypothesis, 1,000 cases each): the bag reader (tpuaf.measure.bag.analyze, the pure entry point
of `tpuaf analyze`) on truncated and garbled copies of a plain bag written with the rosbags
writer. Every case is analysed or refused with BagError naming the bag: nothing else raises."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tpuaf.measure.bag import Analysis, BagError, analyze

from .test_bag import GRID, PlainBag

FUZZ_EXAMPLES = int(os.environ.get("TPUAF_FUZZ_EXAMPLES", "1000"))  # fewer while iterating
FUZZ = settings(max_examples=FUZZ_EXAMPLES, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

_DIR = tempfile.TemporaryDirectory()
# Two robots, a few vertices each, tf poses at 2 Hz and agent events: small, every record kind.
_BAG = PlainBag(GRID, [[0, 1, 2, 7], [24, 23, 22, 17]], rate=2.0, poses="tf",
                events=True).write(Path(_DIR.name) / "run.bag")
GOOD = _BAG.read_bytes()


def _check(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / "fuzzed.bag"
        bag.write_bytes(data)
        try:
            result = analyze(bag, GRID)
        except BagError as err:
            assert "fuzzed.bag" in str(err)
            return
        assert isinstance(result, Analysis)


def test_the_unfuzzed_bag_is_analysed():
    assert isinstance(analyze(_BAG, GRID), Analysis)


@FUZZ
@given(cut=st.integers(0, len(GOOD) - 1))
def test_fuzz_truncated_bag(cut):
    _check(GOOD[:cut])


@FUZZ
@given(flips=st.lists(st.tuples(st.integers(0, len(GOOD) - 1), st.integers(1, 255)),
                      min_size=1, max_size=16),
       insert=st.binary(max_size=16), at=st.integers(0, len(GOOD)))
def test_fuzz_garbled_bag(flips, insert, at):
    data = bytearray(GOOD)
    for i, mask in flips:
        data[i] ^= mask
    data[at:at] = insert
    _check(bytes(data))
