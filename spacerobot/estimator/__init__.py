"""The estimator's Python face (no FMI, no plant): :class:`Identifier` over the native C core
(``native/src/estimator.h`` through :mod:`spacerobot.core.estimator`), the report types, and
the physical-consistency test and projection (:mod:`.physical`, native)."""
from .identifier import BodyEstimate, Identifier, Report, identifier_from_values  # noqa: F401
from .physical import is_physical, project_body  # noqa: F401
