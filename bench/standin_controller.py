"""A stand-in for the controller node, run as its own process by tests/iomodule and bench/hardware_bench.py:
over the hub it starts the I/O module (NMT), then every 10 ms sends SYNC (with counter), the module's RPDO1
(0x6411:1 = CODE) and, every 50 ms, its own heartbeat (OPERATIONAL) as node CONTROLLER_ID. It prints
``running`` once the first cycle went out and runs until killed. Raw python-can frames: no telethermo code
on this side.

    python standin_controller.py PORT MODULE_ID CONTROLLER_ID CODE
"""

from __future__ import annotations

import sys
import time

import can


def main() -> None:
    port, module_id, controller_id, code = (int(a) for a in sys.argv[1:5])
    bus = can.Bus(interface="socketcand", host="127.0.0.1", port=port, channel="vcan0", tcp_tune=True)

    def frame(cob: int, data) -> can.Message:
        return can.Message(arbitration_id=cob, data=bytes(data), is_extended_id=False)

    bus.send(frame(0x000, [0x01, module_id]))  # NMT start the module
    rpdo = frame(0x200 + module_id, code.to_bytes(2, "little", signed=True))
    next_t, k = time.monotonic(), 0
    while True:
        bus.send(frame(0x080, [k % 240 + 1]))  # SYNC, counter 1..240
        bus.send(rpdo)
        if k % 5 == 0:
            bus.send(frame(0x700 + controller_id, [0x05]))  # heartbeat: OPERATIONAL
        if k == 0:
            print("running", flush=True)
        k += 1
        next_t += 0.010
        time.sleep(max(0.0, next_t - time.monotonic()))


if __name__ == "__main__":
    main()
