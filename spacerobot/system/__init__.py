"""The system: SSP generation (:mod:`.ssd`), the co-simulation loop and its parts (:mod:`.reader`,
:mod:`.bindings`, :mod:`.instance`, :mod:`.master`, :mod:`.recorder`, :mod:`.errors`) composed
by :func:`.runner.run_ssp`, the command line, plots, sweeps and cross-check files."""
