"""Estimator numerical core: regressors, RLS solvers and the Identifier (no FMI, no plant)."""
from .. import jit

jit.load(__name__, "kernels")   # compiled equations and RLS step (persistent Numba cache)

from .identifier import Identifier, BodyEstimate  # noqa: E402,F401
from .rls import RLS, ModifiedRLS  # noqa: E402,F401
