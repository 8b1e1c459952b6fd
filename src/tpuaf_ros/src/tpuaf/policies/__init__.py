"""Strategies behind one `Policy` interface, by name. Importing this package registers them all."""

from tpuaf.policies.base import (
    REGISTRY,
    Parameter,
    ParameterError,
    Policy,
    Registry,
    RobotContext,
    RobotContextBase,
    register,
)

__all__ = [
    "REGISTRY",
    "Parameter",
    "ParameterError",
    "Policy",
    "Registry",
    "RobotContext",
    "RobotContextBase",
    "register",
]

# Strategy modules register themselves on import.
from tpuaf.policies import tpuaf, tpuaf_plus  # noqa: E402,F401

# isort: split
# Baselines of BASELINES.md (GBS/SEBS/CBLS, CGG/MSP, DTAG, DTAP, RAND/CR/HCR/HPCC).
from tpuaf.policies import bayesian, cyclic, dtag, dtap, reactive  # noqa: E402,F401
