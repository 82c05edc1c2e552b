"""FMI layer: the shared pythonfmu slave base class and the FMU/SSP build."""
