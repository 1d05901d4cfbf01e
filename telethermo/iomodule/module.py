"""A simulated CiA 401 analog I/O module: a CANopen node of our device layer with a simulated rig behind
its channels (DESIGN.md §11, docs/hardware.md).

Object dictionary: ``bus_config/io_module.eds`` (:mod:`telethermo.bus_config.io_eds`). Behaviour:

- **Plant time is SYNC time.** On every SYNC (PRE-OPERATIONAL or OPERATIONAL) the simulated rig advances
  by the communication cycle period 0x1006 holding the drive current the output applies now; without
  SYNC the plant does not move (the module has no other clock).
- **Inputs.** Every ADC sampling period 0x2100 (plant time; at most one conversion per SYNC) the six
  inputs are converted (:mod:`.scaling`) into 0x6401:1..6; between conversions they hold, as a real
  module's 400 ms default does. TPDO1/TPDO2 carry them on the SYNC that converted them or later.
  An input at full scale reads its sentinel (0x7FFF / 0x8000) and raises EMCY 0xFF10 (data: the channel
  and the code) until it reads a value again; 0x2110 opens inputs on purpose (a wiring fault).
- **Output.** 0x6411:1 (RPDO1, applied on receipt) drives the current amplifier while the module is
  OPERATIONAL and every watched node (0x1016) is alive. Otherwise the output is in its *error state*:
  0x6443:1 = 1 applies the substitute value 0x6444:1, 0 keeps the last value. 0x2101 is the code the
  DAC applies, 0x2102 is 1 in the error state.
- **Communication error.** When a node 0x1016 watches is lost, the device layer sends EMCY 0x8130; the
  module applies the output's error state at once, then 0x1029:1 (0: to PRE-OPERATIONAL if OPERATIONAL,
  1: no change, 2: STOPPED). It leaves the error state when the node's heartbeat is back and (after
  0x1029 took it out of OPERATIONAL) an NMT start.
"""

from __future__ import annotations

import logging
import math
import time
from pathlib import Path
from typing import Callable

import canopen

from telethermo.bus_config import path as bus_config_path
from telethermo.bus_config.io_eds import (
    FILE_NAME,
    N_INPUTS,
    OPEN_CIRCUIT_INDEX,
    OUTPUT_ACTUAL_INDEX,
    OUTPUT_ERROR_INDEX,
    SAMPLING_INDEX,
)
from telethermo.cia301 import EMCY_INPUT_SENTINEL
from telethermo.device import (
    Device,
    DeviceSettings,
    NmtCommand,
    NmtState,
    PeerEvent,
    RpdoEvent,
    SyncTick,
    WriteEvent,
)
from telethermo.iomodule.faults import Faults
from telethermo.iomodule.scaling import (
    DEFAULT_AMPLIFIER_A_PER_V,
    DEFAULT_WIRING,
    OVERLOAD_POS,
    SENTINELS,
    InputWiring,
    counts_to_volts,
    volts_to_counts,
)
from telethermo.rig import SimulatedRig

log = logging.getLogger("telethermo.iomodule")

EDS_PATH = bus_config_path(FILE_NAME)
AI, AO, AO_ERROR_MODE, AO_ERROR_VALUE, ERROR_BEHAVIOUR = 0x6401, 0x6411, 0x6443, 0x6444, 0x1029
#: 0x1029:1 values (CiA 301)
ON_ERROR_PRE_OPERATIONAL, ON_ERROR_NO_CHANGE, ON_ERROR_STOPPED = 0, 1, 2
_OUTPUT_OBJECTS = {AO, AO_ERROR_MODE, AO_ERROR_VALUE, 0x1016}


def input_source(channel: int) -> str:
    """The EMCY source of input ``channel``'s sentinel error (one per channel)."""
    return f"input{channel}"


class IoModule:
    """One simulated I/O module on ``network``: ``IoModule(network, node_id, rig)`` then :meth:`start`.

    ``rig`` is a simulated rig (advanced here, one SYNC at a time); ``wiring`` the amplifiers in front of
    0x6401:1..6; ``amplifier_A_per_V`` the current amplifier behind 0x6411:1; ``faults`` wiring faults
    injected on purpose (:mod:`.faults`, for commissioning tests).
    """

    def __init__(
        self,
        network: canopen.Network,
        node_id: int,
        rig: SimulatedRig,
        *,
        eds: str | Path = EDS_PATH,
        settings: DeviceSettings | None = None,
        wiring: tuple[InputWiring, ...] = DEFAULT_WIRING,
        amplifier_A_per_V: float = DEFAULT_AMPLIFIER_A_PER_V,
        clock: Callable[[], float] = time.monotonic,
        faults: Faults | None = None,
    ):
        if len(wiring) != N_INPUTS:
            raise ValueError(f"wiring: {N_INPUTS} inputs expected, got {len(wiring)}")
        self.rig = rig
        self.faults = faults = faults or Faults()
        self.wiring = faults.wiring(wiring)
        self.amplifier_A_per_V = float(amplifier_A_per_V) * faults.out_sign
        self.clock = clock
        self.device = dev = Device(network, node_id, eds, settings=settings, clock=clock)
        self._since_conversion_s = math.inf
        self.conversions = 0
        self.actual = 0  # DAC code applied now
        self.in_error = False
        #: clock() when the output last entered its error state (None: never), and why
        self.error_since: float | None = None
        self.error_reason = ""
        self._sentinel = [False] * N_INPUTS
        dev.add_sync_handler(self._on_sync)
        dev.add_rpdo_listener(self._on_rpdo)
        dev.add_peer_listener(self._on_peer)
        dev.add_nmt_listener(self._on_nmt)
        dev.add_write_listener(self._on_write)
        if faults.opened:
            dev.write(OPEN_CIRCUIT_INDEX, faults.opened, check=False)

    # ------------------------------------------------------------------ life cycle
    def start(self) -> None:
        """Power on: boot-up, PRE-OPERATIONAL (output in its error state), heartbeat running."""
        with self.device.lock:
            self._apply_output("power-on")
        self.device.start()

    def close(self) -> None:
        self.device.close()

    # ------------------------------------------------------------------ output
    def _comm_error(self) -> int | None:
        """A watched node that is lost (None: every watched node alive or not yet seen)."""
        dev = self.device
        for node in dev.heartbeat.consumers:
            if dev.peer_status(node) == "lost":
                return node
        return None

    def _apply_output(self, why: str) -> None:
        """Decide the DAC code (device lock held) and drive the amplifier with it."""
        dev = self.device
        lost = self._comm_error()
        error = lost is not None or dev.state != NmtState.OPERATIONAL
        if error:
            if int(dev.read((AO_ERROR_MODE, 1))) == 1:
                code = max(-0x8000, min(0x7FFF, int(dev.read((AO_ERROR_VALUE, 1)))))
            else:
                code = self.actual
        else:
            code = int(dev.read((AO, 1)))
        if error and not self.in_error:
            self.error_since = self.clock()
            self.error_reason = f"node {lost} lost" if lost is not None else f"{dev.state.name} ({why})"
            log.warning("output 1 in its error state (%s): %d counts", self.error_reason, code)
        elif not error and self.in_error:
            log.info("output 1 follows 0x6411 again")
        self.in_error = error
        self.actual = code
        dev.write(OUTPUT_ACTUAL_INDEX, code, check=False)
        dev.write(OUTPUT_ERROR_INDEX, int(error), check=False)
        self.rig.apply_current(counts_to_volts(code) * self.amplifier_A_per_V)

    def _on_rpdo(self, event: RpdoEvent) -> None:
        with self.device.lock:
            self._apply_output("RPDO")

    def _on_write(self, event: WriteEvent) -> None:
        if event.index in _OUTPUT_OBJECTS:
            self._apply_output(f"0x{event.index:04X} written")

    def _on_nmt(self, old: NmtState, new: NmtState, command: int | None) -> None:
        with self.device.lock:
            if new == NmtState.INITIALISING:  # a reset: inputs convert again at the next SYNC
                self._since_conversion_s = math.inf
            self._apply_output(f"NMT {old.name} -> {new.name}")

    def _on_peer(self, event: PeerEvent) -> None:
        dev = self.device
        with dev.lock:
            # the output first, whatever 0x1029 says
            self._apply_output(f"node {event.node_id} {event.kind}")
            if event.kind != "lost":
                return
            behaviour = int(dev.read((ERROR_BEHAVIOUR, 1)))
            if behaviour == ON_ERROR_PRE_OPERATIONAL and dev.state == NmtState.OPERATIONAL:
                dev.nmt.apply(NmtCommand.ENTER_PRE_OPERATIONAL)
            elif behaviour == ON_ERROR_STOPPED:
                dev.nmt.apply(NmtCommand.STOP)

    # ------------------------------------------------------------------ SYNC: plant and inputs
    def _on_sync(self, tick: SyncTick) -> None:
        dev = self.device
        dt_s = int(dev.read(0x1006)) * 1e-6 or self.rig.period_s
        self.rig.advance(dt_s)
        self._since_conversion_s += dt_s
        sampling_ms = self.faults.sampling_ms or int(dev.read(SAMPLING_INDEX))
        if self._since_conversion_s + 1e-9 >= sampling_ms * 1e-3:
            self._since_conversion_s = 0.0
            self._convert()

    def _convert(self) -> None:
        """One ADC conversion of every input into 0x6401 (device lock held)."""
        dev = self.device
        sample = self.rig.read()
        opened = int(dev.read(OPEN_CIRCUIT_INDEX))
        for ch, wire in enumerate(self.wiring, 1):
            code = OVERLOAD_POS if opened >> (ch - 1) & 1 else volts_to_counts(wire.volts(sample))
            dev.write((AI, ch), code, check=False)
            bad = code in SENTINELS
            if bad and not self._sentinel[ch - 1]:
                log.warning("input %d (%s) reads its sentinel %d", ch, wire.signal, code)
                data = bytes([ch]) + code.to_bytes(2, "little", signed=True)
                dev.raise_emcy(EMCY_INPUT_SENTINEL, data=data, source=input_source(ch))
            elif not bad and self._sentinel[ch - 1]:
                dev.clear_emcy(EMCY_INPUT_SENTINEL, source=input_source(ch))
            self._sentinel[ch - 1] = bad
        self.conversions += 1
