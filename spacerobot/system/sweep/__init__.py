"""Parameter sweeps of the co-simulation on a Dask cluster, with a resumable CSV table.

A *point* is one co-simulation of the SSP system: robot, target size, identification method,
acceleration source, initial base velocity ``v0``, thruster bound ``F_max``, stop time, and
optionally any further parameter overrides. A *sweep* is the Cartesian product of lists of
these values (given on the command line or in a TOML file).

Every point runs :func:`spacerobot.system.runner.run_ssp` in a Dask worker process (a local
cluster by default: ``distributed.LocalCluster(processes=True, threads_per_worker=1)``, or an
existing scheduler with ``--scheduler``). The .ssp is built once per robot with
:func:`spacerobot.system.ssd.build_system` before any point is submitted and sent to the
workers as data (:mod:`.ship`: once per worker, written once into its scratch space): the
workers need the installed package only, no file system shared with the client.

Results table (CSV, one row per point, appended and flushed as each point finishes):

``sweep_id``
    stable hash of the point's parameters (:func:`point_id`); a re-run skips every point whose
    id is already in the table with ``status == "ok"`` and re-runs failed ones (their old row is
    dropped first, so that the table keeps one row per point). Rows are written by the
    process that runs the sweep, one flushed line per finished point, so an interrupted sweep
    (Ctrl-C, a crash) loses only the points in flight; ``<table>.lock`` keeps a second sweep
    from writing to the same table at the same time.
``robot, target, method, accel_source, v0_x, v0_y, v0_z, v0_norm, F_max, stop_time, overrides``
    the point's parameters (``overrides``: JSON of any extra FMI overrides, ``{}`` if none).
``status, error, wall_time, t_end, worker``
    ``ok`` or ``failed``; the error (exception type and message) of a failed point; wall-clock
    time of the point in its worker [s]; the simulated time reached [s]; ``host:pid`` of the
    worker process that ran it.
``diag.samples, diag.rejected, diag.status``
    the estimator's diagnostics at the end.
``est.<p>, true.<p>, relerr.<p>``
    for every estimated parameter ``<p>`` of the interface (``base.m``, ``base.b[1]`` ...
    ``target.Iyz``): the final estimate, the truth, and the relative error
    ``|est - true| / scale`` with the body-scaled ``scale`` of
    :func:`spacerobot.interface.error_scale` (the mass for ``m``, max(|b_i|, 5 cm) for a CoM
    component, the moment itself for a principal moment, the body's largest moment for a
    product of inertia).

The planar model identifies only ``m``, ``b[1]``, ``b[2]`` and ``Izz`` of each body; the other
columns then hold the untouched initial guesses and are not plotted.

Example TOML (``docs/velocity_study.toml``)::

    robot = "planar"
    target = "medium"
    method = ["momentum", "force"]
    accel = ["measured", "differenced"]
    F_max = 0.1
    stop_time = 60.0
    v0 = [[0, 10], [50, 50], [200, 200]]
    workers = 2
    out = "results/velocity_study.csv"

    [overrides]          # optional extra FMI overrides applied to every point
    "plant.base.omega0[3]" = 0.1
"""
from __future__ import annotations

from .cli import (DEFAULTS, _settings, add_arguments, cli_sweep, load_config, main,  # noqa: F401
                  parse_v0, register)
from .execute import SweepSummary, run_sweep  # noqa: F401
from .plot import PAPER_MOMENTUM_IN, plot_sweep  # noqa: F401
from .points import (IDENTIFIED, PARAMS, Point, expected_truth, make_points,  # noqa: F401
                     point_id)
from .run import DEFAULT_BUILDER, DEFAULT_RUNNER, _resolve, run_point  # noqa: F401
from .table import (COLUMNS, DIAG, POINT_COLUMNS, SweepLocked, _exclusive,  # noqa: F401
                    read_table)
