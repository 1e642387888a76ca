"""Experiments from the paper, each writing a run folder with figures and a summary."""

from tensim.experiments.disturbance import disturbance_loads, run_disturbance, write_disturbance

__all__ = ["disturbance_loads", "run_disturbance", "write_disturbance"]
