"""A bound run: the driver (`run.run_bound`) that builds a world (`sim`), a leg controller (`gaits`) and the
spine, hands their steps to one step loop and measures the log (`metrics`). The loops share one seam
(`stepping`): `python_loop` (every step in Python, the reference), `held_loop` (MuJoCo's held chunks) and
`compiled_loop` (the control half of each step in one numba call: `step_compiled`, `step_kernel`);
`loops.choose_loop` picks one and says why, `backend` picks the per-step code."""
