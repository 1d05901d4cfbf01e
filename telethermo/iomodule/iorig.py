"""The I/O rig driver: a :class:`telethermo.rig.Rig` on standard CANopen I/O modules, configured by a
RIG.toml (:mod:`.rigconfig`), no code (issue 24 item 1; docs/hardware.md). ``--rig io --rig-config RIG.toml``.

At start-up (:meth:`IoRig.start`) the driver opens its own connection to the bus, commissions every module by
SDO (:mod:`.commission`: TPDOs carrying the configured inputs on every SYNC, the RPDO of the output, the
sampling period, 0x6443/0x6444 = substitute the code of 0 A, 0x1016 watching the controller, 0x1029) and reads
it back, then starts the modules (NMT). A module that refuses is named with the object and the abort code
(:class:`IoRigError`).

In the loop: the modules answer each SYNC of the controller with their TPDOs; :meth:`IoRig.read` waits (on the
driver's own receive thread, not the controller's) for the set of TPDOs newer than the last one it returned,
at most ``input_timeout_ms`` (lockstep: ``lockstep_timeout_s``), then scales, checks the sentinels and filters
them. :meth:`IoRig.apply_current` sends the output module's RPDO at once (the same cycle). Inputs missing for
``stale_limit`` periods in a row read NaN: the controller's envelope trips on them.
"""

from __future__ import annotations

import logging
import math
import struct
import threading
from collections.abc import Callable

import canopen

from telethermo.iomodule.commission import CommissionError, ModuleSetup, commission
from telethermo.iomodule.restart import ModuleSupervisor
from telethermo.iomodule.rigconfig import RigConfig
from telethermo.rig import RigSample
from telethermo.transport.bus import TransportSettings, open_bus

log = logging.getLogger("telethermo.iorig")

LOCKSTEP_TIMEOUT_S = 2.5
#: entries per TPDO (8 bytes of 16-bit inputs)
PER_TPDO = 4


class IoRigError(RuntimeError):
    """The modules cannot be reached or refuse their configuration; the message names module and object."""


def _mapping_hint(cfg: RigConfig, exc: CommissionError) -> str:
    """For a refused PDO mapping: which entry of the RIG.toml put that object there, and what to check."""
    if exc.mapped is None:
        return ""
    idx, sub = exc.mapped
    where = [f"signals.{s.name}" for s in cfg.signals.values() if (s.index, s.subindex) == (idx, sub)]
    if (cfg.drive.index, cfg.drive.subindex) == (idx, sub):
        where.append("drive")
    owner = " and ".join(where) or "no entry"
    return f"; 0x{idx:04X}:{sub} is {owner} of the file: is it an object of this module (its EDS or manual)?"


class IoRig:
    """A rig on CANopen I/O modules: ``IoRig(config, transport=..., controller_id=..., period_s=...)``, then
    :meth:`start` (commissioning), then ``read``/``apply_current`` once per SYNC; :meth:`close` at the end."""

    def __init__(
        self,
        config: RigConfig,
        *,
        transport: TransportSettings | None,
        controller_id: int,
        period_s: float,
        lockstep: bool = False,
        network: canopen.Network | None = None,
        sdo_timeout_s: float | None = None,
    ):
        self.config = config
        self.period_s = float(period_s)
        self.I_max_A = float(config.drive.limit_A)
        self.tem = config.tem
        """The TEM's constants of the RIG.toml's ``[tem]`` (None: not given), for
        :func:`telethermo.control.detach.tem_limits`."""
        self.controller_id = controller_id
        self.lockstep = lockstep
        self.timeout_s = (
            LOCKSTEP_TIMEOUT_S
            if lockstep
            else (config.input_timeout_ms * 1e-3 if config.input_timeout_ms else 0.5 * period_s)
        )
        self.sdo_timeout_s = config.sdo_timeout_ms * 1e-3 if sdo_timeout_s is None else sdo_timeout_s
        """How long commissioning waits for each SDO answer, s (default: the RIG.toml's sdo_timeout_ms)."""
        self._transport = transport
        self._own_network = network is None
        self.network = network
        self.nodes: dict[str, canopen.RemoteNode] = {}
        # per module: the TPDOs (cob-id, the signal names they carry, in order)
        self._tpdos: list[tuple[int, tuple[str, ...]]] = []
        self._counts: dict[str, int] = {}
        self._arrived: dict[int, int] = {}
        self._cond = threading.Condition()
        self._consumed = 0
        self._filtered: dict[str, float] = {}
        self.sets = 0
        """Input sets read (the rig's sample clock: t_s = sets × period_s)."""
        self.stale = 0
        """Reads in a row that found no new input set."""
        self.timeouts = 0
        """Reads that waited out the input timeout (``input_timeout_ms``; lockstep: ``LOCKSTEP_TIMEOUT_S``)
        without a new input set, so their cycles reused the last inputs."""
        self.supervisor: ModuleSupervisor | None = None
        """Restarts a module that went PRE-OPERATIONAL while the controller runs (:mod:`.restart`)."""
        self.current_A = 0.0
        self._drive_cob = 0x200 + config.modules[config.drive.module].node_id
        self._last = RigSample(0.0, math.nan, math.nan, math.nan, False, math.nan)

    # ------------------------------------------------------------------ start-up
    def setups(self) -> list[ModuleSetup]:
        """What commissioning writes into each module (the TPDO mapping from the signals it carries)."""
        out = []
        cfg = self.config
        for name, mod in cfg.modules.items():
            entries = [(s.index, s.subindex) for s in cfg.signals.values() if s.module == name]
            tpdos = tuple(tuple(entries[k : k + PER_TPDO]) for k in range(0, len(entries), PER_TPDO))
            drive = cfg.drive if cfg.drive.module == name else None
            out.append(
                ModuleSetup(
                    node_id=mod.node_id,
                    controller_id=self.controller_id,
                    consumer_ms=mod.consumer_ms,
                    cycle_period_us=round(self.period_s * 1e6),
                    sampling_ms=mod.sampling_ms,
                    substitute_counts=drive.zero_counts if drive else 0,
                    error_behaviour=mod.error_behaviour,
                    tpdos=tpdos,
                    rpdo1=(drive.index, drive.subindex) if drive else None,
                    sampling_index=mod.sampling_index,
                )
            )
        return out

    def start(self) -> "IoRig":
        """Open the bus, commission every module (read back), start them; raises IoRigError (the bus then
        released)."""
        try:
            return self._start()
        except BaseException:
            if self._own_network and self.network is not None:
                self.network.disconnect()
                self.network = None
            raise

    def _start(self) -> "IoRig":
        if self.network is None:
            if self._transport is None:
                raise IoRigError(f"{self.config.source}: no bus to reach the modules on")
            self.network = canopen.Network(open_bus(self._transport))
            self.network.connect()
        cfg = self.config
        by_id = {m.node_id: m for m in cfg.modules.values()}
        setups = self.setups()
        for setup in setups:
            mod = by_id[setup.node_id]
            node = self.network.add_node(mod.node_id, str(mod.eds))
            node.sdo.RESPONSE_TIMEOUT = self.sdo_timeout_s
            self.nodes[mod.name] = node
            sdo_log = logging.getLogger("canopen.sdo.client")  # the failure is ours to say, in one line
            level = sdo_log.level
            sdo_log.setLevel(logging.CRITICAL)
            try:
                node.nmt.send_command(0x80)  # PRE-OPERATIONAL: PDO mapping may change
                commission(node, setup)
            except CommissionError as exc:
                hint = _mapping_hint(cfg, exc)
                raise IoRigError(f"{cfg.source}: modules.{mod.name}: {exc}{hint}") from None
            except canopen.SdoCommunicationError as exc:
                bus = self._transport.describe() if self._transport else "the node's bus"
                raise IoRigError(
                    f"{cfg.source}: modules.{mod.name}: node {mod.node_id} does not answer SDO ({exc}); "
                    f"is the module powered, set to node-ID {mod.node_id}, and on this bus ({bus})?"
                ) from None
            finally:
                sdo_log.setLevel(level)
            names = [s.name for s in cfg.signals.values() if s.module == mod.name]
            for k in range(0, len(names), PER_TPDO):
                cob = 0x180 + 0x100 * (k // PER_TPDO) + mod.node_id
                self._tpdos.append((cob, tuple(names[k : k + PER_TPDO])))
        for cob, _ in self._tpdos:
            self._arrived[cob] = 0
            self.network.subscribe(cob, self._on_tpdo)
        self.apply_current(0.0)
        for node in self.nodes.values():
            node.nmt.send_command(0x01)  # OPERATIONAL: the output follows our RPDO
        self.supervisor = ModuleSupervisor(
            self.network, self.nodes, {s.node_id: s for s in setups}, source=str(cfg.source)
        )
        self.supervisor.start()
        log.info("%s: %d module(s) commissioned and started", cfg.source, len(self.nodes))
        return self

    def close(self) -> None:
        """Drive to 0 A, modules to PRE-OPERATIONAL (their output applies the substitute), bus released."""
        if self.network is None:
            return
        if self.supervisor is not None:  # no restart of the modules we now put into PRE-OPERATIONAL
            self.supervisor.stop()
        try:
            self.apply_current(0.0)
            for node in self.nodes.values():
                node.nmt.send_command(0x80)
        except Exception as exc:  # the bus may be gone already
            log.warning("close: %s", exc)
        for cob, _ in self._tpdos:
            self.network.unsubscribe(cob)
        if self._own_network:
            self.network.disconnect()
        self.network = None

    def watch_controller(self, controller_ok: Callable[[], tuple[bool, bool]]) -> None:
        """``controller_ok() -> (OPERATIONAL, link healthy)`` of the controller driving this rig: while both
        hold, a module reporting PRE-OPERATIONAL or a boot-up is checked and started again."""
        if self.supervisor is not None:
            self.supervisor.controller_ok = controller_ok

    @property
    def module_restarts(self) -> int:
        """NMT STARTs sent to modules that had left OPERATIONAL while the controller ran."""
        return self.supervisor.restarts if self.supervisor is not None else 0

    # ------------------------------------------------------------------ loop
    def _on_tpdo(self, cob: int, data: bytearray, timestamp: float) -> None:
        names = dict(self._tpdos)[cob]
        values = struct.unpack_from(f"<{len(names)}h", bytes(data).ljust(2 * len(names), b"\0"))
        with self._cond:
            self._counts.update(zip(names, values))
            self._arrived[cob] += 1
            self._cond.notify_all()

    def counts(self) -> dict[str, int]:
        """The raw 16-bit input codes of the newest TPDOs, by signal name (for commissioning checks)."""
        with self._cond:
            return dict(self._counts)

    def silent_modules(self) -> str:
        """The modules whose TPDOs have not brought the input set the loop waits for, as
        ``"modules.NAME (node N)"`` (comma-separated; call with the inputs' lock held or after the loop)."""
        by_node = {m.node_id: m.name for m in self.config.modules.values()}
        nodes = sorted({cob & 0x7F for cob, n in self._arrived.items() if n <= self._consumed})
        return ", ".join(f"modules.{by_node.get(k, '?')} (node {k})" for k in nodes) or "no module"

    def _complete(self) -> int:
        return min(self._arrived.values()) if self._arrived else 0

    def read(self) -> RigSample:
        """The inputs of the newest SYNC (waiting for them at most the input timeout), scaled and filtered."""
        with self._cond:
            fresh = self._cond.wait_for(lambda: self._complete() > self._consumed, self.timeout_s)
            if not fresh:
                self.timeouts += 1
                self.stale += 1
                if self.stale >= self.config.stale_limit:
                    if self.stale == self.config.stale_limit:  # once per outage: which module went silent
                        log.warning(
                            "%s: no inputs for %d periods from %s: every signal reads NaN (the envelope "
                            "trips on it); is the module powered, on this bus, OPERATIONAL?",
                            self.config.source,
                            self.stale,
                            self.silent_modules(),
                        )
                    self._last = RigSample(self._last.t_s, math.nan, math.nan, math.nan, False, math.nan)
                return self._last
            if self.stale >= self.config.stale_limit:
                log.warning("%s: inputs back after %d periods", self.config.source, self.stale)
            self.stale = 0
            self.sets += 1
            self._consumed = self._complete()
            counts = dict(self._counts)
        self._last = self.decode(counts, t_s=self.sets * self.period_s)
        return self._last

    def read_sdo(self) -> RigSample:
        """The inputs read by SDO (no SYNC needed: before the loop, or for a check), scaled and filtered."""
        counts = {}
        for s in self.config.signals.values():
            node = self.nodes[s.module]
            obj = node.object_dictionary[s.index]
            var = obj if isinstance(obj, canopen.objectdictionary.ODVariable) else obj[s.subindex]
            counts[s.name] = int(var.decode_raw(node.sdo.upload(s.index, s.subindex)))
        self._last = self.decode(counts, t_s=self.sets * self.period_s)
        return self._last

    def decode(self, counts: dict[str, int], *, t_s: float) -> RigSample:
        """Counts by signal name into a sample (scaling, sentinels -> NaN, filters)."""
        vals: dict[str, float] = {}
        for name, s in self.config.signals.items():
            v = s.value(counts[name])
            if s.filter_tau_ms > 0 and math.isfinite(v):
                prev = self._filtered.get(name)
                a = self.period_s / (self.period_s + s.filter_tau_ms * 1e-3)
                v = v if prev is None or not math.isfinite(prev) else prev + a * (v - prev)
            self._filtered[name] = v
            vals[name] = v
        contact_s = self.config.signals["contact"]
        touched = math.isfinite(vals["contact"]) and vals["contact"] >= contact_s.threshold
        force = vals.get("force_N", 0.0)
        return RigSample(
            t_s=t_s,
            T_sensor_C=vals["T_sensor_C"],
            Q_W=vals["Q_W"],
            current_A=vals["current_A"],
            contact=touched,
            T_sink_C=vals["T_sink_C"],
            force_N=force if touched else 0.0,
        )

    def apply_current(self, current_A: float) -> None:
        """The drive's RPDO, now: ``current_A`` clipped to the drive's limit, in counts."""
        code = self.config.drive.counts(current_A)
        self.current_A = float(current_A) if current_A == current_A else 0.0
        self.network.send_message(self._drive_cob, struct.pack("<h", code))
