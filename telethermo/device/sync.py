"""SYNC producer with counter (0x1005 bit 30, 0x1006, 0x1019) that also ticks its own device.

A node never receives its own frames, so :meth:`SyncProducer.transmit` sends the SYNC and then runs
the producing device's own SYNC processing (RPDO commit, SYNC handlers, TPDOs) in the caller's
thread. The schedule (lockstep: SYNC k+1 after the peer's PDO k, seen with
:meth:`telethermo.device.device.Device.wait_rpdo`; or real time) is the node program's: the one
SYNC scheduler is ``nodes.runtime.NodeRuntime.run_producer``.
"""

from __future__ import annotations

from telethermo.device.device import Device, NmtState, SyncTick


class SyncProducer:
    """SYNC producer of ``device`` (which must have 0x1005 bit 30 set)."""

    def __init__(self, device: Device):
        self.device = device
        self.counter = 0  # last counter sent (0: none yet)
        self.sent = 0
        device.add_nmt_listener(self._on_nmt)

    def _on_nmt(self, old: NmtState, new: NmtState, command: int | None) -> None:
        if new not in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):
            # outside PRE-OPERATIONAL/OPERATIONAL (STOPPED, a reset) the counter restarts: the next SYNC
            # carries 1, as CANopenNode's CO_SYNC_process (counter = 0 while not pre/operational)
            self.counter = 0

    def transmit(self) -> SyncTick | None:
        """Send one SYNC (with the next counter value if 0x1019 > 0) and tick the own device.

        Returns the own device's SyncTick, or None without sending anything in STOPPED (CiA 301: a
        stopped node produces no SYNC; an NMT start resumes it, the counter restarting at 1). Raises
        RuntimeError if this device is not the SYNC producer or is not powered on (INITIALISING:
        before ``start()`` or after ``close()``).

        The device lock is held from sending SYNC k until the own SYNC k is processed: a peer that
        answers SYNC k faster than this thread reaches its own tick would otherwise have its TPDO k
        committed as an RPDO of SYNC k (one cycle early) instead of SYNC k+1. With the lock held, the
        receive thread waits and stores that PDO as pending for the next SYNC.
        """
        dev = self.device
        with dev.lock:
            if not dev.is_sync_producer:
                raise RuntimeError(f"node {dev.node_id} is not the SYNC producer (0x1005 bit 30 is clear)")
            if dev.state is NmtState.STOPPED:
                return None  # NMT STOP from any master: no SYNC, and nothing to raise into a SYNC loop
            if dev.state not in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):
                raise RuntimeError(f"node {dev.node_id} may not produce SYNC in {dev.state.name}")
            overflow = dev.core.u(0x1019, 0)
            if overflow:
                self.counter = self.counter + 1 if 0 < self.counter < overflow else 1
                counter: int | None = self.counter
                dev.core.send(dev.sync_cob_id, bytes((self.counter,)))
            else:
                counter = None
                dev.core.send(dev.sync_cob_id, b"")
            self.sent += 1
            return dev.process_sync(counter)
