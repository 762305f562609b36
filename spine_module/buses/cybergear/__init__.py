"""Xiaomi CyberGear actuators on CAN: frame codec (`protocol`), bus-load model (`busload`), per-joint
configuration (`config`, `motors.toml`) and the `CanMotorBus` backend (`driver`)."""

from spine_module.buses.cybergear.backend import make_bus
from spine_module.buses.cybergear.busload import bus_load, frame_bits, max_loop_rate_hz
from spine_module.buses.cybergear.config import CyberGearConfig, JointConfig, load_config
from spine_module.buses.cybergear.driver import CanMotorBus, install_stop_handlers, open_bus

__all__ = [
           "CanMotorBus",
           "CyberGearConfig",
           "JointConfig",
           "bus_load",
           "frame_bits",
           "install_stop_handlers",
           "load_config",
           "make_bus",
           "max_loop_rate_hz",
           "open_bus",
]
