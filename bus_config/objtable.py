"""Every manufacturer object (0x2000..) that is not an operator parameter, one row each: measurements,
estimates, the peer's values received by PDO, the TEM model's objects, commands, status and device-layer
diagnostics (the operator parameters are the rows of ``bus_config/partable.py``). With the parameter
table, these rows are the whole manufacturer part of both object dictionaries: ``od_manufacturer.py``
merges the two in index order, and ``python -m telethermo.bus_config.edsgen`` writes the EDS files and the
docs tables from them (``--check``: tests/bus_config/test_partable.py).

A row (:class:`ObjRow`) holds the index, name (ending in its unit, see ``edsgen``), CiA data type, what the
object is (``kind``), its unit, access, default and range (writable objects), PDO flag and, for an ARRAY,
its number of entries and their names (``sub_name`` + 1..n); its one line of documentation is in
:data:`DOCS`. Each row is written with the constructor of its kind (``_measured`` .. ``_diagnostic``),
which sets what the kind implies (access, PDO flag, default), so a row gives only what is its own. The
objects are the same on both nodes (a node leaves the ones of the other's role at their default).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Union

from telethermo.bus_config.od_types import (
    BOOLEAN,
    REAL32,
    REAL64,
    UNSIGNED8,
    UNSIGNED16,
    UNSIGNED32,
    VISIBLE_STRING,
    Obj,
    Var,
    _real,
    _real64,
    _uint,
    array_obj,
)

Num = Union[int, float, str]

# kinds: what an object is, and who writes it
MEASURED = "measured"  # the node, from its rig, each cycle (read-only on the bus)
ESTIMATE = "estimate"  # the node, from its control core, each cycle
RECEIVED = "received"  # the peer's value, written by an RPDO (limits apply to SDO writes only)
MODEL = "model"  # the TEM model's objects, written by SDO, taken by model_command
COMMAND = "command"  # written by SDO to make the node act (reads 0 or the last request)
STATUS = "status"  # the node's state, written by the node
DIAGNOSTIC = "diagnostic"  # the device layer's counters, read from telethermo.device
KINDS = (MEASURED, ESTIMATE, RECEIVED, MODEL, COMMAND, STATUS, DIAGNOSTIC)


@dataclass(frozen=True)
class ObjRow:
    """One manufacturer object that is not an operator parameter."""

    index: int
    name: str
    data_type: int
    kind: str
    unit: str
    access: str = "ro"
    default: Num = 0
    low: Num | None = None
    high: Num | None = None
    pdo: bool = False
    subs: int = 0
    """An ARRAY of ``subs`` entries (sub-index 1..subs, named ``sub_name`` + i); 0: a VAR."""
    sub_name: str = ""

    @property
    def doc(self) -> str:
        return DOCS[self.name]

    def entry(self, name: str) -> Var:
        """The object's VAR (or one entry of its ARRAY) named ``name``."""
        t, a, d, lo, hi = self.data_type, self.access, self.default, self.low, self.high
        if t == REAL32:
            v = _real(name, a, d, lo, hi, pdo=self.pdo, description=self.doc)
        elif t == REAL64:
            v = _real64(name, a, d, lo, hi, description=self.doc)
        elif t == VISIBLE_STRING:
            v = Var(name, t, a, str(d), description=self.doc)
        else:
            v = _uint(name, t, a, d, lo, hi, pdo=self.pdo, description=self.doc)
        return Var(v.name, v.data_type, v.access, v.default, v.low, v.high, v.pdo, v.description, self.unit)

    def obj(self) -> Obj:
        """The object dictionary object."""
        if not self.subs:
            return Obj(self.index, self.name, var=self.entry(self.name))
        entries = [self.entry(f"{self.sub_name}{i}") for i in range(1, self.subs + 1)]
        return array_obj(self.index, self.name, entries)


# One constructor a kind: each says once what the kind implies (who writes it, so its access and range;
# whether a PDO carries it), a row gives only what is its own.


def _measured(index: int, name: str, data_type: int, unit: str = "") -> ObjRow:
    """Measured by the node from its rig each cycle: read-only, PDO-mappable."""
    return ObjRow(index, name, data_type, MEASURED, unit, pdo=True)


def _estimate(index: int, name: str, data_type: int, unit: str = "") -> ObjRow:
    """Estimated by the node's control core each cycle: read-only, PDO-mappable."""
    return ObjRow(index, name, data_type, ESTIMATE, unit, pdo=True)


def _received(index: int, name: str, data_type: int, unit: str, low: Num, high: Num) -> ObjRow:
    """The peer's value, written by an RPDO: "rww", default 0, PDO-mappable (``low``..``high`` limit SDO
    writes only)."""
    zero = 0.0 if data_type in (REAL32, REAL64) else 0
    return ObjRow(index, name, data_type, RECEIVED, unit, "rww", zero, low, high, pdo=True)


def _model(
    index: int,
    name: str,
    data_type: int,
    unit: str,
    default: Num,
    low: Num,
    high: Num,
    *,
    subs: int = 0,
    sub_name: str = "",
) -> ObjRow:
    """One of the TEM model's objects: written by SDO ("rw", ``low``..``high``), never PDO-mapped."""
    return ObjRow(index, name, data_type, MODEL, unit, "rw", default, low, high, subs=subs, sub_name=sub_name)


def _command(index: int, name: str, data_type: int, high: int) -> ObjRow:
    """A command: written by SDO ("rw", 0..``high``), dimensionless, default 0."""
    return ObjRow(index, name, data_type, COMMAND, "", "rw", 0, 0, high)


def _status(
    index: int, name: str, data_type: int, unit: str = "", *, pdo: bool = False, default: Num = 0
) -> ObjRow:
    """The node's state, written by the node: read-only."""
    return ObjRow(index, name, data_type, STATUS, unit, default=default, pdo=pdo)


def _diagnostic(index: int, name: str) -> ObjRow:
    """A counter of the device layer: UNSIGNED32, read-only, dimensionless."""
    return ObjRow(index, name, UNSIGNED32, DIAGNOSTIC, "")


#: every manufacturer object that is not an operator parameter, in index order
OBJECTS: tuple[ObjRow, ...] = (
    _measured(0x2000, "T_sensor_C", REAL32, "degC"),
    _measured(0x2001, "Q_W", REAL32, "W"),
    _measured(0x2002, "current_A", REAL32, "A"),
    _measured(0x2003, "T_sink_C", REAL32, "degC"),
    _measured(0x2004, "contact", BOOLEAN),
    _measured(0x2005, "force_N", REAL32, "N"),
    _estimate(0x2006, "contact_decision", BOOLEAN),
    _estimate(0x2100, "estimate_C", REAL32, "degC"),
    _estimate(0x2101, "T_pred_C", REAL32, "degC"),
    _estimate(0x2102, "T_cmd_C", REAL32, "degC"),
    _received(0x2103, "peer_estimate_C", REAL32, "degC", -273.15, 1000.0),
    _received(0x2104, "peer_Q_W", REAL32, "W", -1000.0, 1000.0),
    _received(0x2105, "peer_contact", BOOLEAN, "", 0, 1),
    _model(0x2300, "narma_n", UNSIGNED8, "", 3, 0, 8),
    _model(0x2301, "narma_m", UNSIGNED8, "", 3, 0, 8),
    _model(0x2302, "narma_p", UNSIGNED8, "", 3, 0, 4),
    _model(0x2303, "narma_q", UNSIGNED8, "", 3, 0, 4),
    _model(0x2304, "model_period_s", REAL32, "s", 0.01, 0.0005, 1.0),
    _model(0x2305, "model_T_ref_C", REAL32, "degC", 25.0, -20.0, 80.0),
    _model(0x2306, "theta_len", UNSIGNED8, "", 0, 0, 48),
    _model(0x2307, "flux_n", UNSIGNED8, "", 0, 0, 8),
    _model(0x2308, "flux_m", UNSIGNED8, "", 0, 0, 7),
    _model(0x230A, "model_I_min_A", REAL64, "A", -1.0, -10.0, 10.0),
    _model(0x230B, "model_I_max_A", REAL64, "A", 1.0, -10.0, 10.0),
    _model(0x230C, "flux_with_current", BOOLEAN, "", 0, 0, 1),
    _command(0x230D, "model_command", UNSIGNED8, 2),
    _status(0x230E, "model_status", UNSIGNED8),
    _status(0x230F, "model_crc32", UNSIGNED32),
    _model(0x2310, "theta", REAL64, "", 0.0, -1.0e6, 1.0e6, subs=48, sub_name="theta"),
    _model(0x2311, "flux_coeffs", REAL64, "", 0.0, -1.0e6, 1.0e6, subs=16, sub_name="flux_coeff"),
    _command(0x240A, "fault_reset", UNSIGNED8, 1),
    _status(0x2610, "identified_material", UNSIGNED8, pdo=True),
    _status(0x2611, "identified_beta", REAL32, pdo=True),
    _status(0x2612, "identified_se_ln_b", REAL32),
    _status(0x2613, "identified_posterior", REAL32),
    _status(0x2614, "identified_touches", UNSIGNED16, pdo=True),
    _received(0x2615, "peer_identified_material", UNSIGNED8, "", 0, 255),
    _received(0x2616, "peer_identified_touches", UNSIGNED16, "", 0, 0xFFFF),
    _received(0x2617, "peer_identified_beta", REAL32, "", -1.0e6, 1.0e6),
    _status(0x2619, "link_fallback_active", BOOLEAN, pdo=True),
    _status(0x261A, "identified_T_object0_C", REAL32, "degC", pdo=True),
    _received(0x261B, "peer_identified_T_object0_C", REAL32, "degC", -273.15, 1000.0),
    _status(0x261C, "identified_early_material", UNSIGNED8, pdo=True),
    _status(0x261D, "identified_early_posterior", REAL32),
    _status(0x261E, "identified_stage", UNSIGNED8, pdo=True),
    _received(0x261F, "peer_identified_early_material", UNSIGNED8, "", 0, 255),
    _received(0x2620, "peer_identified_stage", UNSIGNED8, "", 0, 2),
    _status(0x2700, "safety_state", UNSIGNED8, pdo=True),
    _status(0x2701, "last_trip_code", UNSIGNED16, pdo=True),
    _status(0x2702, "cycle_counter", UNSIGNED32, pdo=True),
    _status(0x2703, "late_cycles", UNSIGNED32, pdo=True),
    _status(0x2704, "lockstep", BOOLEAN, pdo=True),
    _status(0x2705, "peer_alive", BOOLEAN, pdo=True),
    _status(0x2706, "active_trips", UNSIGNED16, pdo=True),
    _status(0x2707, "fault_reset_blocked_by", UNSIGNED16),
    _status(0x2708, "limits_active", UNSIGNED8),
    _status(0x2709, "input_timeouts", UNSIGNED32),
    _status(0x270A, "module_restarts", UNSIGNED32),
    _diagnostic(0x2710, "malformed_frames"),
    _diagnostic(0x2711, "unknown_cobid_frames"),
    _diagnostic(0x2712, "callback_errors"),
    _diagnostic(0x2713, "sync_count"),
    _diagnostic(0x2714, "rpdo_count"),
    _diagnostic(0x2715, "peer_losses"),
    _status(0x2720, "store_state", UNSIGNED8),
    _status(0x2721, "store_saved_unix_s", UNSIGNED32, "s"),
    _status(0x2722, "store_file", VISIBLE_STRING, default="-"),
    _status(0x2807, "ident_sample", UNSIGNED32, pdo=True),
    _status(0x2808, "ident_state", UNSIGNED8, pdo=True),
    _status(0x2809, "ident_guard", UNSIGNED32),
    _status(0x280A, "ident_start_cycle", UNSIGNED32),
    _command(0x280B, "ident_fetch_sample", UNSIGNED32, 1_000_000),
    _status(0x280C, "ident_fetched_T_sensor_C", REAL32, "degC"),
    _status(0x280D, "ident_fetched_current_A", REAL32, "A"),
    _status(0x280E, "ident_fetched_Q_W", REAL32, "W"),
)
BY_NAME: dict[str, ObjRow] = {o.name: o for o in OBJECTS}


#: one line of documentation per object (the EDS Description= key)
DOCS: dict[str, str] = {
    "T_sensor_C": "flux-sensor mid-plane thermocouple, filtered",
    "Q_W": "heat flux out of the pad into what touches it (>0 warms it)",
    "current_A": "measured TEM current (>0 heats the pad)",
    "T_sink_C": "heat-sink temperature",
    "contact": "contact detector: 1 while touched",
    "force_N": "contact force (0 if not measured)",
    "contact_decision": "the controller's contact decision (its detector, or the rig's flag), sent in TPDO5",
    "estimate_C": "own estimate sent in TPDO1: finger T_f (master, eq. 30) / object T_o (slave, eq. 31)",
    "T_pred_C": "TEM surface temperature predicted by the model (eq. 32)",
    "T_cmd_C": "temperature command after the safety envelope",
    "peer_estimate_C": "peer's estimate, received in RPDO1 (limits apply to SDO writes only)",
    "peer_Q_W": "peer's heat flux, received in RPDO1 (limits apply to SDO writes only)",
    "peer_contact": "peer's contact detector, received in RPDO2 (the probe touches something)",
    "narma_n": "output lags n",
    "narma_m": "input lags m",
    "narma_p": "polynomial order p of a_i in I",
    "narma_q": "polynomial order q of b_j in I",
    "model_period_s": "sample period the model was identified at",
    "model_T_ref_C": "reference temperature of the model",
    "theta_len": "number of valid entries of theta",
    "flux_n": "flux model order n (c_1..c_n)",
    "flux_m": "flux model order m (d_0..d_m)",
    "model_I_min_A": "lowest current of the model's training data (stability is checked over the range)",
    "model_I_max_A": "highest current of the model's training data",
    "flux_with_current": "1: flux_coeffs also hold e_1..e_m, g_1..g_m, h_1..h_m (current terms)",
    "model_command": (
        "write 1: load the model held in 0x2300..0x2311 (refused with 0x08000020 if it is inconsistent or "
        "unstable), 2: unload it (reads 0)"
    ),
    "model_status": "0 no model, 1 loaded (the objects hold the running model), 2 edited since loaded",
    "model_crc32": "CRC-32 of the running model's objects (telethermo.ident.odmodel.od_crc32), 0 none",
    "theta": "NARMA parameter (eq. 11 order)",
    "flux_coeffs": "c_1..c_n, d_0..d_m (eq. 12), then e, g, h if flux_with_current",
    "fault_reset": (
        "write 1: clear the latched trips whose cause is gone (refused with 0x08000022 while one persists: "
        "nothing cleared) (reads 0)"
    ),
    "identified_material": (
        "material of the last touch (its first 0.3 s): code in the rendering table as material_code, 0 none"
        " (no estimate, or the master)"
    ),
    "identified_beta": (
        "relative effusivity b/b_skin of the last touched object, as material_beta (b_skin 951 "
        "W*s^0.5/(m2*K) as in the rendering table, 0 none)"
    ),
    "identified_se_ln_b": "standard error of ln(effusivity), about its relative error (0 none)",
    "identified_posterior": "posterior of identified_material",
    "identified_touches": "touches evaluated (wraps)",
    "peer_identified_material": "the slave's identified_material, received in RPDO2 (master)",
    "peer_identified_touches": (
        "the slave's identified_touches, received in RPDO2 (a change: a new identification)"
    ),
    "peer_identified_beta": (
        "the slave's identified_beta, received in RPDO2 (limits apply to SDO writes only)"
    ),
    "link_fallback_active": (
        "1 while the master renders the last identified material because the slave is lost (EMCY 0xFF01 "
        "when it starts)"
    ),
    "identified_T_object0_C": (
        "(slave) initial temperature of the last touched object, from the same fit (0 none), sent in TPDO6"
    ),
    "peer_identified_T_object0_C": "the slave's identified_T_object0_C, received in RPDO3 (master)",
    "identified_early_material": (
        "(slave, in TPDO6) the last touch's first answer (0.3 s), coded as identified_material"
    ),
    "identified_early_posterior": "(slave) posterior of identified_early_material (0 none or unknown)",
    "identified_stage": (
        "(slave, sent in TPDO6) which answer identified_material holds: 0 none, 1 first, 2 refined"
    ),
    "peer_identified_early_material": "the slave's identified_early_material, received in RPDO3 (master)",
    "peer_identified_stage": "the slave's identified_stage, received in RPDO3 (master)",
    "safety_state": "0 ok, 1 limiting, 2 ramp to neutral, 3 current cut",
    "last_trip_code": "EMCY code of the last trip (0 none)",
    "cycle_counter": "control cycles run",
    "late_cycles": "real-time cycles that missed their slot",
    "input_timeouts": "rig reads that waited out the input timeout and reused the last inputs (--rig io)",
    "module_restarts": (
        "NMT STARTs sent to an I/O module that left OPERATIONAL while this node ran (--rig io)"
    ),
    "lockstep": "1 lockstep, 0 real time",
    "peer_alive": "1 while the peer's heartbeat is seen",
    "active_trips": (
        "latched safety trips, bit i: the i-th trip of telethermo.control.safety.Trip (0x080 heat_sink, "
        "0x200 peer_lost, ...)"
    ),
    "fault_reset_blocked_by": "the trips whose cause persisted at the last refused fault reset (same bits)",
    "limits_active": (
        "the envelope's limits that acted in the last cycle: bit 0 setpoint clamp (a target beyond the "
        "clamps saturates there), 1 ramp, 2 hot cap, 3 guard, 4 current limit, 5 neutral ramp, 6 cut, 7 "
        "slew"
    ),
    "malformed_frames": "frames with a wrong length, ignored",
    "unknown_cobid_frames": "frames with a COB-ID outside the contract",
    "callback_errors": "exceptions caught in application callbacks",
    "sync_count": "SYNC objects processed",
    "rpdo_count": "RPDOs accepted",
    "peer_losses": "heartbeat-consumer timeouts",
    "store_state": (
        "0 no - defaults, 1 yes - restored at boot, 2 no - store file refused at boot, defaults, 3 yes - "
        "saved, 4 no - defaults from the next reset"
    ),
    "store_saved_unix_s": "when the store in force was saved, s since 1970-01-01 UTC (0: none)",
    "store_file": "the node's store file (--store)",
    "ident_sample": (
        "sample j of the experiment is sent with j + 1 (values above the plan's total: done, 0 A held)"
    ),
    "ident_state": "0 not run, 1 running, 2 done, 3 interrupted (the mode changed before the end)",
    "ident_guard": "samples whose current the guard flipped or cut",
    "ident_start_cycle": "control cycles run before the experiment's first sample",
    "ident_fetch_sample": (
        "write j: sample j of the last experiment into 0x280C..0x280E (a sample lost on the bus is fetched "
        "again by SDO) (no such sample: abort 0x08000024)"
    ),
    "ident_fetched_T_sensor_C": "T_sensor_C of the fetched sample",
    "ident_fetched_current_A": "current_A commanded after the fetched sample",
    "ident_fetched_Q_W": "Q_W of the fetched sample",
}
