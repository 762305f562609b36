"""Sim-vs-measured gap workflow: trials, replay, effect library, selection, report."""
