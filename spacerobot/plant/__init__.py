"""Plant numerical core: Pinocchio dynamics, controllers, RK4 simulator (no FMI)."""
from .. import jit

jit.load(__name__, "kernels")   # compiled controllers and RK4 stages (persistent Numba cache)

from .simulator import Plant, Controls  # noqa: E402,F401
