"""One description of a run (`Scenario`), its defaults, its checks and its files.

    from sparc_quad.scenario import Scenario, bound_config
    s = Scenario(host="solo12", gait="raibert", speed=0.9, kx=800, dx=10, duration=5)

The command line (`sparc-quad bound`), a study cell and Python all build one; `bound_config` is the only
place a scenario becomes the simulator's configuration.
"""

from sparc_quad.scenario.files import SCENARIO_FILE, document, load_scenario, to_toml, write_scenario
from sparc_quad.scenario.model import DEFAULTS, GAITS, KEYS, Key, Scenario, ScenarioError
from sparc_quad.scenario.resolve import bound_config, defaults, resolved, spine_of

__all__ = ["DEFAULTS", "GAITS", "KEYS", "SCENARIO_FILE", "Key", "Scenario", "ScenarioError", "bound_config",
           "defaults", "document", "load_scenario", "resolved", "spine_of", "to_toml", "write_scenario"]
