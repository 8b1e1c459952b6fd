"""User-input errors: one base class, one subclass per kind of input.

Every error a user can cause (a bad option, parameter, map, world or settings file) derives from
`TpuafError`; the `tpuaf` command prints its message as one line and exits with code 2, never a
traceback. The base class itself lives in `tpuaf_core` (the package every other one depends on)
so that `tpuaf_stage.WorldError`, which may not import tpuaf, shares it.
"""

from __future__ import annotations

from tpuaf_core import TpuafError

__all__ = ["CliError", "MapError", "TpuafError"]


class CliError(TpuafError):
    """A command-line option or its combination is invalid."""


class MapError(TpuafError):
    """A map, graph or map settings file is malformed; the message names the file and line."""
