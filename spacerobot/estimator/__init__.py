"""Estimator numerical core (no FMI, no plant): the Identifier (validation, equations of a
sample, bookkeeping, the reported physically consistent estimates and their identified flags),
the two solvers behind one interface, the RLS filters and the maps
between parameterisations."""
from .. import jit

jit.load(__name__, "kernels")   # compiled equations and RLS step (persistent Numba cache)
jit.load(__name__, "report_kernels", deps=("kernels",))   # compiled standard deviations, projection

from .identifier import BodyEstimate, ExcitationRequest, Identifier, Report  # noqa: E402,F401
from .physical import is_physical, project_body  # noqa: E402,F401
from .rls import RLS, ModifiedRLS  # noqa: E402,F401
from .solvers import JointSolver, PaperSolver, ParameterSolver, make_solver  # noqa: E402,F401
