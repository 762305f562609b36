"""Helpers shared by the CAN tests: a private virtual CAN channel with emulated motors and a sniffer."""

from __future__ import annotations

import contextlib
import threading
import uuid
from collections.abc import Iterator

import can

from sparc_quad.sim.cybergear_emulator import CyberGearEmulator
from spine_module.buses.cybergear import protocol as P


class Sniffer(can.Listener):
    """Records every frame on the channel (thread-safe)."""

    def __init__(self) -> None:
        self.frames: list[can.Message] = []
        self._lock = threading.Lock()

    def on_message_received(self, msg: can.Message) -> None:
        with self._lock:
            self.frames.append(msg)

    def of_type(self, comm: int, target: int | None = None) -> list[can.Message]:
        with self._lock:
            return [m for m in self.frames if P.split_id(m.arbitration_id)[0] == comm
                    and (target is None or (m.arbitration_id & 0xFF) == target)]

    def clear(self) -> None:
        with self._lock:
            self.frames.clear()


@contextlib.contextmanager
def virtual_rig(ids=(1, 2, 3), lockstep: bool = True, **emu_kw) -> Iterator[tuple[str, CyberGearEmulator,
                                                                                   Sniffer]]:
    """A fresh virtual channel with an emulator and a sniffer; yields (channel, emulator, sniffer)."""
    channel = f"test-{uuid.uuid4().hex[:10]}"
    ebus = can.Bus(interface="virtual", channel=channel)
    sbus = can.Bus(interface="virtual", channel=channel)
    sniffer = Sniffer()
    notifier = can.Notifier(sbus, [sniffer], timeout=0.05)
    emu = CyberGearEmulator(ebus, ids, lockstep=lockstep, **emu_kw)
    try:
        yield channel, emu, sniffer
    finally:
        emu.shutdown()
        notifier.stop()
        ebus.shutdown()
        sbus.shutdown()


def rig_config(**kw):
    """The packaged config with silent-motor and motor CAN timeouts that tolerate a loaded CI machine
    (stalls of ~80 ms were seen here with 5 users on 2 cores)."""
    from spine_module.buses.cybergear import load_config
    return load_config().with_(**{"silent_timeout_s": 0.5, "can_timeout_s": 0.5, **kw})


def stops_to(sniffer: Sniffer, motor_id: int) -> int:
    return len(sniffer.of_type(P.CommType.STOP, motor_id))


def wait_for(pred, timeout_s: float = 5.0) -> bool:
    """Poll a predicate (tests assert on the result, not on the time it took)."""
    ev = threading.Event()
    for _ in range(int(timeout_s / 0.005)):
        if pred():
            return True
        ev.wait(0.005)
    return bool(pred())
