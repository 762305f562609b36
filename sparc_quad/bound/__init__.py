"""A bound run: the driver that steps a world (`sim`), a leg controller (`gaits`) and the spine together
and measures the result (`metrics`). `run.run_bound` is the reference Python loop; `compiled_loop` runs the
same steps in one numba call (`step_compiled`, `step_kernel`) where it can; `backend` chooses."""
