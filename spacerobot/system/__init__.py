"""The system: SSP generation, co-simulation runner, command line, plots, sweeps."""
