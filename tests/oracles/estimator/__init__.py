"""The test oracle: an independent NumPy formulation of the estimator (the Numba kernels run as
plain Python, ``_nonumba``; the paper solver takes its layered NumPy path,
``PaperSolver.fused = False``). It imports nothing from ``spacerobot``: its layout, codes and
guess handling are in :mod:`.layout`, its parameter maps in :mod:`.parameters`, its projection
onto real bodies in :mod:`.physical`. The library's Identifier runs the native core; the tests
compare it with this one within tolerances.

Estimator numerical core (no FMI, no plant): the Identifier (validation, equations of a
sample, bookkeeping, the reported physically consistent estimates and their identified flags),
the two solvers behind one interface, the RLS filters and the maps
between parameterisations."""
from .identifier import BodyEstimate, ExcitationRequest, Identifier, Report  # noqa: E402,F401
from .physical import is_physical, project_body  # noqa: E402,F401
from .rls import RLS, ModifiedRLS  # noqa: E402,F401
from .solvers import JointSolver, PaperSolver, ParameterSolver, make_solver  # noqa: E402,F401

PaperSolver.fused = False   # the layered NumPy path (no fused compiled step)
