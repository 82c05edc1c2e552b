"""Plant numerical core: Pinocchio dynamics, controllers, RK4 simulator (no FMI)."""
from .simulator import Plant, Controls  # noqa: F401
