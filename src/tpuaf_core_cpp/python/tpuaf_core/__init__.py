"""tpuaf_core: the compiled C++ core of tpuaf, re-exported.

Units: metres, seconds, radians. Equation numbers refer to the TPUAF paper (SPEC section 3-4).
"""

from ._core import *  # noqa: F401,F403
from ._core import __doc__  # noqa: F401


class TpuafError(ValueError):
    """Base of every user-input error of the tpuaf packages (a map, world or settings file, a
    node parameter, a command-line option): the message is one line naming the problem.

    It lives here, in the package every other one depends on, so that tpuaf_stage (which must
    not import tpuaf) and tpuaf share it; tpuaf re-exports it as tpuaf.errors.TpuafError."""
