"""The paper's bench experiments (Section IV) run on the simulated bench: static, dynamic, PD."""
