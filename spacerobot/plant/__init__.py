"""Plant numerical core: Pinocchio dynamics, controllers, RK4 simulator (no FMI)."""
from .. import jit

jit.load(__name__, "rigid_body")                          # compiled ABA, CRBA, RNEA, momentum
jit.load(__name__, "kernels", deps=("rigid_body",))       # controllers, RK4 (persistent cache)

from .simulator import Plant, Controls  # noqa: E402,F401
