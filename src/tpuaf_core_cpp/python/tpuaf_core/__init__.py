"""tpuaf_core: the compiled C++ core of tpuaf, re-exported.

Units: metres, seconds, radians. Equation numbers refer to the TPUAF paper (SPEC section 3-4).
"""

from ._core import *  # noqa: F401,F403
from ._core import __doc__  # noqa: F401
