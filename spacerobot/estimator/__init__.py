"""Estimator numerical core: regressors, RLS solvers and the Identifier (no FMI, no plant)."""
from .identifier import Identifier, BodyEstimate  # noqa: F401
from .rls import RLS, ModifiedRLS  # noqa: F401
