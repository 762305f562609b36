"""The spine node: the 1 kHz loop between the motor bus and the LCM interface (see `runner`)."""

from spine_module.node.controllers import Controllers
from spine_module.node.io import InProcessNodeIO, LcmNodeIO, NodeIO
from spine_module.node.runner import NodeConfig, RunResult, SpineNode, run_lockstep, run_realtime

__all__ = ["Controllers", "InProcessNodeIO", "LcmNodeIO", "NodeConfig", "NodeIO", "RunResult", "SpineNode",
           "run_lockstep", "run_realtime"]
