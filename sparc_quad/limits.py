"""Limits of what a run can be, shared by the command line (`cli.args`) and the scenario
(`scenario.model`): one number each, with its reason. Imports nothing, so every layer may read them."""

SEED_MAX = 2**32 - 1  # numpy's and pybullet's seed range
SIM_DURATION_MAX_S = 600.0  # a simulated run keeps its whole 1 kHz log in memory (docs/cli.md)
SIM_DURATION_MIN_S = 1e-3  # one 1 kHz physics step: a shorter run simulates nothing
