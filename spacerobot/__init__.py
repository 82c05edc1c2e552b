"""spacerobot: online identification of base and target inertial parameters of a space robot
after capture (Zhang, Yue, Yuan, IEEE Access 2020), as FMI 2.0 co-simulation components."""

__version__ = "0.1.0"
