"""spacerobot: online identification of base and target inertial parameters of a space robot
after capture (Zhang, Yue, Yuan, IEEE Access 2020), as FMI 2.0 co-simulation components.

The public API (imported lazily, so that ``import spacerobot`` pulls neither Pinocchio nor Numba
nor fmpy until a name that needs them is used)::

    from spacerobot import scenario, build_system, run_ssp
    sc = scenario("planar", "medium")                 # robot, target, initial state, guesses
    paths = build_system("planar", "build/planar")    # both FMUs, SSD, SSVs, planar.ssp
    res = run_ssp(paths["ssp"], parameter_set="large", stop_time=30.0)
    res.final, res.truth, res.relative_errors()

    from spacerobot import Identifier, Plant          # the numerical cores, without FMI
    from spacerobot import SensorSuite                # the sensor models, without FMI
"""

__version__ = "0.1.0"

#: public name -> module that defines it
_API = {
    # robots, scenarios and the interface (numpy only)
    "scenario": "spacerobot.robots", "ROBOTS": "spacerobot.robots",
    "TARGETS": "spacerobot.robots", "PAPER_PLANAR_MEDIUM": "spacerobot.robots",
    "PARAMETER_SETS": "spacerobot.robots", "random_scenario": "spacerobot.robots",
    "robot_spec": "spacerobot.robots", "load_robot": "spacerobot.urdf",
    "ESTIMATE_NAMES": "spacerobot.interface", "METHODS": "spacerobot.interface",
    "SOLVERS": "spacerobot.interface", "ACCEL_SOURCES": "spacerobot.interface",
    "estimate_vector": "spacerobot.interface", "relative_errors": "spacerobot.interface",
    "identified_estimates": "spacerobot.interface", "error_scale": "spacerobot.interface",
    # numerical cores (the plant: the native C core through ctypes)
    "Identifier": "spacerobot.estimator", "Plant": "spacerobot.plant",
    "project_body": "spacerobot.estimator",
    "is_physical": "spacerobot.estimator",
    "SensorSuite": "spacerobot.sensors", "identify_csv": "spacerobot.system.identify",
    # FMUs, the system and its co-simulation (fmpy, lxml)
    "build_fmu": "spacerobot.fmi.build", "build_system": "spacerobot.system.ssd",
    "run_ssp": "spacerobot.system.runner", "RunResult": "spacerobot.system.runner",
    "SimulationError": "spacerobot.system.errors", "read_csv": "spacerobot.system.recorder",
    "FMUInstance": "spacerobot.system.instance", "Master": "spacerobot.system.master",
    "logger_callbacks": "spacerobot.system.instance",
    # studies on Dask
    "make_cases": "spacerobot.system.montecarlo", "run_montecarlo": "spacerobot.system.montecarlo",
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    module = _API.get(name)
    if module is None:
        raise AttributeError(f"module 'spacerobot' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value                  # later look-ups skip this function
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
