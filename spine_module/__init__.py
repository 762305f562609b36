"""SPARC spine module: what runs on the robot (model, controllers, node, motor buses, safety).

Never imports pybullet: the simulator lives in `sparc_quad`.
"""

__version__ = "0.1.0"
