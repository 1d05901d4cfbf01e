"""The object dictionary of both nodes, written once, rendered to CiA 306 EDS text.

``bus_config/master.eds`` and ``bus_config/slave.eds`` are generated from the tables below (and
checked in: they are the contract other tools read). Regenerate after editing this file::

    python -m telethermo.bus_config.edsgen          # rewrites master.eds and slave.eds (atomically)
    python -m telethermo.bus_config.edsgen --check  # exit 1 if the checked-in files differ

Naming convention (the operator CLI ``get``/``set`` and the bus monitor rely on it):

- Communication objects (0x1000..0x1FFF) keep their CiA 301 names.
- Manufacturer objects (0x2000..) have snake_case names that end in their unit:
  ``_C`` °C, ``_W`` W, ``_A`` A, ``_N`` N, ``_s`` s, ``_C_per_s`` °C/s, ``_A_per_C`` A/°C,
  ``_A_per_C_s`` A/(°C·s), ``_A_per_W`` A/W, ``_C_per_W`` °C/W; no suffix = dimensionless
  (count, code, flag, model order). The same unit is in the non-standard ``Unit=`` key (ASCII:
  ``degC``, ``W``, ...), which canopen reads into ``ODVariable.unit``.
- Every writable manufacturer object has ``LowLimit``/``HighLimit``. REAL32 limits are written as
  decimals (canopen's parser drops them; telethermo.device.eds_info re-reads them).
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path

from telethermo.bus_config import path as _path
from telethermo.atomic import write_text_atomic

# CiA 301 data types
BOOLEAN, INTEGER8, INTEGER16, INTEGER32 = 0x0001, 0x0002, 0x0003, 0x0004
UNSIGNED8, UNSIGNED16, UNSIGNED32, REAL32, VISIBLE_STRING = 0x0005, 0x0006, 0x0007, 0x0008, 0x0009
REAL64 = 0x0011

# CiA 306 [FileInfo] dates (mm-dd-yyyy, hh:mm(AM|PM)): of the object dictionary's last change, set by hand
# (the files are generated, so they must not change with the clock)
EDS_DATE, EDS_TIME = "11-23-2026", "10:00PM"

UNIT_TEXT = {  # name suffix -> ASCII unit for the Unit= key (longest suffixes first when matching)
    "_A_per_C_s": "A/(degC*s)", "_A_per_C": "A/degC", "_A_per_W": "A/W", "_C_per_s": "degC/s",
    "_C_per_W": "degC/W", "_C": "degC", "_W": "W", "_A": "A", "_N": "N", "_s": "s", "_mm": "mm",
}

NODE_IDS = {"master": 1, "slave": 2}
#: TPDO5 (the contact flag, 1 byte, every SYNC) goes on 0x680 + node-ID: outside CiA 301's predefined
#: connection set and its restricted COB-IDs (0x680..0x6DF are free), so no other device's default uses it.
#: It is sent after TPDO1 in the same SYNC, so a peer that has it has the TPDO1 of the same cycle too.
CONTACT_PDO_BASE = 0x680
#: the slave's TPDO6 (identified object temperature, every 10th SYNC) on 0x6C0 + node-ID (free range); the master's
#: RPDO3 takes it event-driven (type 255), so the lockstep producer (waits for the last synchronous RPDO) does not
IDENT_PDO_BASE = 0x6C0
TPDO_STATUS_TRANSMISSION_TYPE = 10  # status TPDOs 2..4 go with every 10th SYNC (bus load at 1 kHz)


@dataclass(frozen=True)
class Var:
    """One variable (a VAR object, or one sub-entry of an ARRAY/RECORD)."""

    name: str
    data_type: int
    access: str  # ro, wo, rw, rwr, rww, const
    default: str
    low: str | None = None
    high: str | None = None
    pdo: bool = False
    description: str = ""

    @property
    def unit(self) -> str:
        for suffix, text in UNIT_TEXT.items():
            if self.name.endswith(suffix):
                return text
        return ""


@dataclass(frozen=True)
class Obj:
    """An object: a VAR (``var``) or an ARRAY/RECORD (``subs``, sub-index -> Var)."""

    index: int
    name: str
    var: Var | None = None
    subs: dict[int, Var] = field(default_factory=dict)
    object_type: int = 0x7  # 0x7 VAR, 0x8 ARRAY, 0x9 RECORD


def _f(x: float) -> str:
    return repr(float(x))


def _real(name, access, default, low=None, high=None, pdo=False, description=""):
    return Var(name, REAL32, access, _f(default), None if low is None else _f(low),
               None if high is None else _f(high), pdo, description)


def _real64(name, access, default, low=None, high=None, description=""):
    """A REAL64 entry: identified model coefficients cancel to ~1e-8 (see docs/identification.md), so
    REAL32 would make a transferred NARMA model unstable; they are SDO-only (never PDO-mapped)."""
    return Var(name, REAL64, access, _f(default), None if low is None else _f(low),
               None if high is None else _f(high), False, description)


def _uint(name, data_type, access, default, low=None, high=None, pdo=False, description=""):
    return Var(name, data_type, access, f"0x{default:X}" if isinstance(default, int) else default,
               None if low is None else f"0x{low:X}", None if high is None else f"0x{high:X}", pdo, description)


def _pdo_comm(index: int, title: str, cob_id: str, trans_type: int, tpdo: bool) -> Obj:
    subs = {
        0: _uint("Highest sub-index supported", UNSIGNED8, "const", 6 if tpdo else 5),
        1: _uint(f"COB-ID used by {'TPDO' if tpdo else 'RPDO'}", UNSIGNED32, "rw", cob_id),
        2: _uint("Transmission type", UNSIGNED8, "rw", trans_type),
    }
    if tpdo:
        subs[3] = _uint("Inhibit time", UNSIGNED16, "rw", 0, description="100 us units")
    subs[5] = _uint("Event timer", UNSIGNED16, "rw", 0, description="ms, 0: off")
    if tpdo:
        subs[6] = _uint("SYNC start value", UNSIGNED8, "rw", 0, 0, 240)
    return Obj(index, title, subs=subs, object_type=0x9)


def _pdo_map(index: int, title: str, entries: list[int]) -> Obj:
    subs = {0: _uint("Number of mapped application objects in PDO", UNSIGNED8, "rw", len(entries), 0, 8)}
    for i in range(1, 9):
        subs[i] = _uint(f"Application object {i}", UNSIGNED32, "rw", entries[i - 1] if i <= len(entries) else 0)
    return Obj(index, title, subs=subs, object_type=0x9)


def _mapping(index: int, sub: int, bits: int) -> int:
    return (index << 16) | (sub << 8) | bits


# power-on gains per role (A/degC, A/(degC*s), A/W). Neutral placeholders: a node program writes its
# controller's parameters (gains, estimator, R_sensor, safety limits, mode, rendering settings: read from
# telethermo/control/defaults.py at run time, see nodes/odparams.py) into the OD before Device.start()
# and after a reset node. (The CLI tests read these values; changing them needs tests/cli updated too.)
GAINS = {"master": (0.5, 0.1, 0.0), "slave": (0.5, 0.1, 0.0)}


def manufacturer_objects(role: str = "master") -> list[Obj]:
    """0x2000..: measurements, estimates, gains, model, safety, mode, rendering, status, diagnostics."""
    kp, ki, kq = GAINS[role]
    V = lambda idx, var: Obj(idx, var.name, var=var)  # noqa: E731
    ro_pdo = dict(pdo=True)
    objs = [
        # -- measurements (written by the node from its rig each cycle; read-only on the bus)
        V(0x2000, _real("T_sensor_C", "ro", 0.0, **ro_pdo, description="flux-sensor mid-plane thermocouple, filtered")),
        V(0x2001, _real("Q_W", "ro", 0.0, **ro_pdo, description="heat flux out of the pad into what touches it (>0 warms it)")),
        V(0x2002, _real("current_A", "ro", 0.0, **ro_pdo, description="measured TEM current (>0 heats the pad)")),
        V(0x2003, _real("T_sink_C", "ro", 0.0, **ro_pdo, description="heat-sink temperature")),
        V(0x2004, _uint("contact", BOOLEAN, "ro", 0, **ro_pdo, description="contact detector: 1 while touched")),
        V(0x2005, _real("force_N", "ro", 0.0, **ro_pdo, description="contact force (0 if not measured)")),
        V(0x2006, _uint("contact_decision", BOOLEAN, "ro", 0, **ro_pdo,
                        description="the controller's contact decision (its detector, or the rig's flag), sent in TPDO5")),
        # -- estimates
        V(0x2100, _real("estimate_C", "ro", 0.0, **ro_pdo,
                        description="own estimate sent in TPDO1: finger T_f (master, eq. 30) / object T_o (slave, eq. 31)")),
        V(0x2101, _real("T_pred_C", "ro", 0.0, **ro_pdo, description="TEM surface temperature predicted by the model (eq. 32)")),
        V(0x2102, _real("T_cmd_C", "ro", 0.0, **ro_pdo, description="temperature command after the safety envelope")),
        V(0x2103, _real("peer_estimate_C", "rww", 0.0, -273.15, 1000.0, pdo=True,
                        description="peer's estimate, received in RPDO1 (limits apply to SDO writes only)")),
        V(0x2104, _real("peer_Q_W", "rww", 0.0, -1000.0, 1000.0, pdo=True,
                        description="peer's heat flux, received in RPDO1 (limits apply to SDO writes only)")),
        V(0x2105, _uint("peer_contact", BOOLEAN, "rww", 0, 0, 1, pdo=True,
                        description="peer's contact detector, received in RPDO2 (the probe touches something)")),
        # -- controller (eq. 33-35)
        V(0x2200, _real("kp_A_per_C", "rw", kp, 0.0, 20.0, description="proportional gain")),
        V(0x2201, _real("ki_A_per_C_s", "rw", ki, 0.0, 20.0, description="integral gain")),
        V(0x2202, _real("kQ_A_per_W", "rw", kq, -20.0, 20.0, description="heat-flux feed-forward gain (peer's flux)")),
        V(0x2203, _uint("estimator", UNSIGNED8, "rw", 0, 0, 2,
                        description="eq. 30/31, 2*T_sensor - T_pred, with T_pred from: 0 the NARMA model (eq. 32), "
                                    "1 the flux sensor, T1 of eq. 28 as T_sensor + Q*R_sensor/2 (default), 2 both fused "
                                    "(0 and 2 need a loaded model: model_status 1)")),
        # -- model parameters (NARMA eq. 10, flux ARMA eq. 12)
        V(0x2300, _uint("narma_n", UNSIGNED8, "rw", 3, 0, 8, description="output lags n")),
        V(0x2301, _uint("narma_m", UNSIGNED8, "rw", 3, 0, 8, description="input lags m")),
        V(0x2302, _uint("narma_p", UNSIGNED8, "rw", 3, 0, 4, description="polynomial order p of a_i in I")),
        V(0x2303, _uint("narma_q", UNSIGNED8, "rw", 3, 0, 4, description="polynomial order q of b_j in I")),
        V(0x2304, _real("model_period_s", "rw", 0.01, 0.0005, 1.0, description="sample period the model was identified at")),
        V(0x2305, _real("model_T_ref_C", "rw", 25.0, -20.0, 80.0, description="reference temperature of the model")),
        V(0x2306, _uint("theta_len", UNSIGNED8, "rw", 0, 0, 48, description="number of valid entries of theta")),
        V(0x2307, _uint("flux_n", UNSIGNED8, "rw", 0, 0, 8, description="flux model order n (c_1..c_n)")),
        V(0x2308, _uint("flux_m", UNSIGNED8, "rw", 0, 0, 7, description="flux model order m (d_0..d_m)")),
        V(0x2309, _real("R_sensor_C_per_W", "rw", 2.0, 0.0, 1000.0, description="flux-sensor thermal resistance e/(kS), eq. 29")),
        V(0x230A, _real64("model_I_min_A", "rw", -1.0, -10.0, 10.0,
                          description="lowest current of the model's training data (stability is checked over the range)")),
        V(0x230B, _real64("model_I_max_A", "rw", 1.0, -10.0, 10.0, description="highest current of the model's training data")),
        V(0x230C, _uint("flux_with_current", BOOLEAN, "rw", 0, 0, 1,
                        description="1: flux_coeffs also hold e_1..e_m, g_1..g_m, h_1..h_m (current terms)")),
        V(0x230D, _uint("model_command", UNSIGNED8, "rw", 0, 0, 2,
                        description="write 1: load the model held in 0x2300..0x2311 (refused with 0x08000020 if it is "
                                    "inconsistent or unstable), 2: unload it (reads 0)")),
        V(0x230E, _uint("model_status", UNSIGNED8, "ro", 0,
                        description="0 no model, 1 loaded (the objects hold the running model), 2 edited since loaded")),
        V(0x230F, _uint("model_crc32", UNSIGNED32, "ro", 0,
                        description="CRC-32 of the running model's objects (telethermo.ident.odmodel.od_crc32), 0 none")),
        Obj(0x2310, "theta", object_type=0x8, subs={
            0: _uint("Highest sub-index supported", UNSIGNED8, "const", 48),
            **{i: _real64(f"theta{i}", "rw", 0.0, -1.0e6, 1.0e6, description="NARMA parameter (eq. 11 order)")
               for i in range(1, 49)}}),
        Obj(0x2311, "flux_coeffs", object_type=0x8, subs={
            0: _uint("Highest sub-index supported", UNSIGNED8, "const", 16),
            **{i: _real64(f"flux_coeff{i}", "rw", 0.0, -1.0e6, 1.0e6, description="c_1..c_n, d_0..d_m (eq. 12), then e, g, h if flux_with_current")
               for i in range(1, 17)}}),
        # -- safety envelope (DESIGN.md section 6): ranges only allow narrowing the defaults
        V(0x2400, _real("T_min_C", "rw", 15.0, 15.0, 43.0,
                        description="lowest surface setpoint, must not exceed neutral_C and must stay more than 1 degC "
                                    "(two 0.5 degC guard bands) below T_max_C")),
        V(0x2401, _real("T_max_C", "rw", 43.0, 15.0, 43.0,
                        description="highest surface setpoint, must not be below neutral_C and must stay more than 1 degC "
                                    "(two 0.5 degC guard bands) above T_min_C")),
        V(0x2402, _real("ramp_limit_C_per_s", "rw", 5.0, 0.01, 5.0, description="setpoint ramp limit")),
        V(0x2403, _real("hot_threshold_C", "rw", 41.0, 30.0, 43.0, description="time-at-temperature threshold")),
        V(0x2404, _real("hot_time_limit_s", "rw", 30.0, 0.0, 600.0, description="longest time above hot_threshold_C")),
        V(0x2405, _real("current_limit_A", "rw", 1.6, 0.0, 10.0, description="current limit, at most 0.8 Imax of the rig (the node writes its own: 2.4 A on the simulated 3 A rig)")),
        V(0x2406, _real("sink_trip_C", "rw", 55.0, 20.0, 55.0, description="heat-sink trip temperature")),
        V(0x2407, _real("neutral_C", "rw", 32.0, 28.0, 36.0, description="neutral temperature on peer loss, must lie within [T_min_C, T_max_C]")),
        V(0x2408, _uint("peer_pdo_miss_limit", UNSIGNED16, "rw", 10, 1, 1000, description="missed peer PDOs (cycles) before peer loss")),
        V(0x2409, _real("mismatch_limit_C", "rw", 12.0, 0.1, 20.0, description="model-vs-sensor plausibility limit")),
        V(0x240A, _uint("fault_reset", UNSIGNED8, "rw", 0, 0, 1,
                        description="write 1: clear the latched trips whose cause is gone (refused with 0x08000022 "
                                    "while one persists: nothing cleared) (reads 0)")),
        # -- mode (telethermo.control.types.Mode)
        V(0x2500, _uint("mode", UNSIGNED8, "rw", 0, 0, 3, pdo=True,
                        description="0 idle, 1 telepresence, 2 render, 3 identify (render on the master only)")),
        # -- virtual rendering (yamamoto eq. 5/7)
        V(0x2600, _uint("material_code", UNSIGNED8, "rw", 0, 0, 255,
                        description="0 custom (material_beta), k from 1: the k-th material of the rendering table "
                                    "(telethermo/data/render_materials.toml, in file order)")),
        V(0x2601, _real("material_beta", "rw", 1.0, 0.001, 1000.0, description="relative effusivity of the object (eq. 6)")),
        V(0x2602, _real("object_T0_C", "rw", 25.0, -20.0, 100.0, description="initial object temperature")),
        V(0x2603, _real("finger_T0_C", "rw", 33.0, 20.0, 40.0, description="initial finger temperature")),
        V(0x2604, _real("pad_beta", "rw", 1.0, 0.001, 1000.0, description="relative effusivity of the pad")),
        # -- later phase of a rendered touch (issue 15; telethermo.control.later_phase)
        V(0x2605, _uint("later_model", UNSIGNED8, "rw", 0, 0, 2,
                        description="after the first instant: 0 semi-infinite (eq. 1 for the whole touch), 1 RC "
                                    "(benali-khoudja 4), 2 conduction model of the object (1 and 2 need a material of "
                                    "telethermo/data/render_objects.toml)")),
        V(0x2606, _real("object_thickness_mm", "rw", 20.0, 0.01, 1000.0, description="virtual object thickness, mm")),
        V(0x2607, _uint("object_back", UNSIGNED8, "rw", 0, 0, 1,
                        description="virtual object back face: 0 adiabatic, 1 losing to ambient air")),
        # -- material identification (slave; written by the node from telethermo.control.material_stream)
        V(0x2610, _uint("identified_material", UNSIGNED8, "ro", 0, pdo=True,
                        description="material of the last touch (its first 0.3 s): code in the rendering table as "
                                    "material_code, 0 none (no estimate, or the master)")),
        V(0x2611, _real("identified_beta", "ro", 0.0, pdo=True,
                        description="relative effusivity b/b_skin of the last touched object, as material_beta "
                                    "(b_skin 951 W*s^0.5/(m2*K) as in the rendering table, 0 none)")),
        V(0x2612, _real("identified_se_ln_b", "ro", 0.0,
                        description="standard error of ln(effusivity), about its relative error (0 none)")),
        V(0x2613, _real("identified_posterior", "ro", 0.0, description="posterior of identified_material")),
        V(0x2614, _uint("identified_touches", UNSIGNED16, "ro", 0, pdo=True, description="touches evaluated (wraps)")),
        # -- graceful link loss (issue 15; telethermo.control.link_fallback): the slave's identification, received
        # by the master in RPDO2 with the contact flag (the slave's TPDO5), and the master's fallback
        V(0x2615, _uint("peer_identified_material", UNSIGNED8, "rww", 0, 0, 255, pdo=True,
                        description="the slave's identified_material, received in RPDO2 (master)")),
        V(0x2616, _uint("peer_identified_touches", UNSIGNED16, "rww", 0, 0, 0xFFFF, pdo=True,
                        description="the slave's identified_touches, received in RPDO2 (a change: a new identification)")),
        V(0x2617, _real("peer_identified_beta", "rww", 0.0, -1.0e6, 1.0e6, pdo=True,
                        description="the slave's identified_beta, received in RPDO2 (limits apply to SDO writes only)")),
        V(0x2618, _real("link_loss_render_s", "rw", 5.0, 0.0, 60.0,
                        description="(master, telepresence) slave lost while the operator touches an identified "
                                    "material: render it locally this long before the ramp to neutral (0: at once)")),
        V(0x2619, _uint("link_fallback_active", BOOLEAN, "ro", 0, **ro_pdo,
                        description="1 while the master renders the last identified material because the slave is "
                                    "lost (EMCY 0xFF01 when it starts)")),
        V(0x261A, _real("identified_T_object0_C", "ro", 0.0, pdo=True,
                        description="(slave) initial temperature of the last touched object, from the same fit "
                                    "(0 none), sent in TPDO6")),
        V(0x261B, _real("peer_identified_T_object0_C", "rww", 0.0, -273.15, 1000.0, pdo=True,
                        description="the slave's identified_T_object0_C, received in RPDO3 (master)")),
        # -- identification experiment (IDENTIFY mode; telethermo.ident.plan.IdentifyPlan)
        V(0x2800, _uint("ident_seed", UNSIGNED16, "rw", 0, 0, 0xFFFF, description="PRBS seed (held-out: seed + 1)")),
        V(0x2801, _uint("ident_rest_samples", UNSIGNED32, "rw", 200, 0, 100_000, description="samples at 0 A first")),
        V(0x2802, _uint("ident_train_samples", UNSIGNED32, "rw", 10_000, 1, 500_000, description="training PRBS samples")),
        V(0x2803, _uint("ident_validation_samples", UNSIGNED32, "rw", 5_000, 1, 500_000,
                        description="held-out PRBS samples")),
        V(0x2804, _real("ident_amplitude_min_A", "rw", 0.1, 0.0, 10.0,
                        description="smallest PRBS bit amplitude, must not exceed ident_amplitude_max_A nor change "
                                    "while identifying (mode 3)")),
        V(0x2805, _real("ident_amplitude_max_A", "rw", 1.0, 0.0, 10.0,
                        description="largest PRBS bit amplitude, must not be below ident_amplitude_min_A nor change "
                                    "while identifying (mode 3)")),
        V(0x2806, _uint("ident_hold_samples", UNSIGNED16, "rw", 25, 1, 10_000, description="samples per PRBS bit")),
        V(0x2807, _uint("ident_sample", UNSIGNED32, "ro", 0, pdo=True,
                        description="sample j of the experiment is sent with j + 1 (values above the plan's total: done, 0 A held)")),
        V(0x2808, _uint("ident_state", UNSIGNED8, "ro", 0, pdo=True,
                        description="0 not run, 1 running, 2 done, 3 interrupted (the mode changed before the end)")),
        V(0x2809, _uint("ident_guard", UNSIGNED32, "ro", 0, description="samples whose current the guard flipped or cut")),
        V(0x280A, _uint("ident_start_cycle", UNSIGNED32, "ro", 0,
                        description="control cycles run before the experiment's first sample")),
        V(0x280B, _uint("ident_fetch_sample", UNSIGNED32, "rw", 0, 0, 1_000_000,
                        description="write j: sample j of the last experiment into 0x280C..0x280E (a sample lost on "
                                    "the bus is fetched again by SDO) (no such sample: abort 0x08000024)")),
        V(0x280C, _real("ident_fetched_T_sensor_C", "ro", 0.0, description="T_sensor_C of the fetched sample")),
        V(0x280D, _real("ident_fetched_current_A", "ro", 0.0, description="current_A commanded after the fetched sample")),
        V(0x280E, _real("ident_fetched_Q_W", "ro", 0.0, description="Q_W of the fetched sample")),
        # -- status (written by the node)
        V(0x2700, _uint("safety_state", UNSIGNED8, "ro", 0, **ro_pdo,
                        description="0 ok, 1 limiting, 2 ramp to neutral, 3 current cut")),
        V(0x2701, _uint("last_trip_code", UNSIGNED16, "ro", 0, **ro_pdo, description="EMCY code of the last trip (0 none)")),
        V(0x2702, _uint("cycle_counter", UNSIGNED32, "ro", 0, **ro_pdo, description="control cycles run")),
        V(0x2703, _uint("late_cycles", UNSIGNED32, "ro", 0, **ro_pdo, description="real-time cycles that missed their slot")),
        V(0x2704, _uint("lockstep", BOOLEAN, "ro", 0, **ro_pdo, description="1 lockstep, 0 real time")),
        V(0x2705, _uint("peer_alive", BOOLEAN, "ro", 0, **ro_pdo, description="1 while the peer's heartbeat is seen")),
        V(0x2706, _uint("active_trips", UNSIGNED16, "ro", 0, **ro_pdo,
                        description="latched safety trips, bit i: the i-th trip of telethermo.control.safety.Trip "
                                    "(0x080 heat_sink, 0x200 peer_lost, ...)")),
        V(0x2707, _uint("fault_reset_blocked_by", UNSIGNED16, "ro", 0,
                        description="the trips whose cause persisted at the last refused fault reset (same bits)")),
        # -- device-layer diagnostics (written by telethermo.device)
        V(0x2710, _uint("malformed_frames", UNSIGNED32, "ro", 0, description="frames with a wrong length, ignored")),
        V(0x2711, _uint("unknown_cobid_frames", UNSIGNED32, "ro", 0, description="frames with a COB-ID outside the contract")),
        V(0x2712, _uint("callback_errors", UNSIGNED32, "ro", 0, description="exceptions caught in application callbacks")),
        V(0x2713, _uint("sync_count", UNSIGNED32, "ro", 0, description="SYNC objects processed")),
        V(0x2714, _uint("rpdo_count", UNSIGNED32, "ro", 0, description="RPDOs accepted")),
        V(0x2715, _uint("peer_losses", UNSIGNED32, "ro", 0, description="heartbeat-consumer timeouts")),
    ]
    return objs


def _contact_pdo(contact: int, material: int, touches: int, beta: int, identification: bool) -> list[int]:
    """The contact PDO's mapping: the flag, slave -> master also its identification (code, touches, beta: 8 bytes)."""
    extra = [_mapping(material, 0, 8), _mapping(touches, 0, 16), _mapping(beta, 0, 32)] if identification else []
    return [_mapping(contact, 0, 8)] + extra


def communication_objects(role: str) -> list[Obj]:
    """0x1000..0x1FFF for ``role`` (master: node 1, SYNC producer; slave: node 2)."""
    own, peer = NODE_IDS[role], NODE_IDS["slave" if role == "master" else "master"]
    V = lambda idx, var: Obj(idx, var.name, var=var)  # noqa: E731
    objs = [
        V(0x1000, _uint("Device type", UNSIGNED32, "ro", 0, description="no device profile")),
        V(0x1001, _uint("Error register", UNSIGNED8, "ro", 0, pdo=True)),
        Obj(0x1003, "Pre-defined error field", object_type=0x8, subs={
            0: _uint("Number of errors", UNSIGNED8, "rw", 0, description="write 0 to clear the history (other values: abort 0x06090030)"),
            **{i: _uint(f"Standard error field {i}", UNSIGNED32, "ro", 0) for i in range(1, 9)}}),
        V(0x1005, _uint("COB-ID SYNC", UNSIGNED32, "rw", 0x40000080 if role == "master" else 0x80,
                        description="bit 30 set: this node produces SYNC")),
        V(0x1006, _uint("Communication cycle period", UNSIGNED32, "rw", 10000, 0, 10_000_000, description="us")),
        V(0x1008, Var("Manufacturer device name", VISIBLE_STRING, "const", f"telethermo {role}")),
        V(0x1009, Var("Manufacturer hardware version", VISIBLE_STRING, "const", "sim")),
        V(0x100A, Var("Manufacturer software version", VISIBLE_STRING, "const", "0.1.0")),
        V(0x1014, _uint("COB-ID EMCY", UNSIGNED32, "ro", "$NODEID+0x80")),
        V(0x1015, _uint("Inhibit time EMCY", UNSIGNED16, "rw", 10, 0, 0xFFFF, description="100 us units")),
        Obj(0x1016, "Consumer heartbeat time", object_type=0x8, subs={
            0: _uint("Highest sub-index supported", UNSIGNED8, "const", 2),
            1: _uint("Consumer heartbeat time 1", UNSIGNED32, "rw", (peer << 16) | 250,
                     description="the peer: bits 16-23 node-ID, bits 0-15 time in ms"),
            2: _uint("Consumer heartbeat time 2", UNSIGNED32, "rw", 0,
                     description="spare (0: unused): bits 16-23 node-ID, bits 0-15 time in ms")}),
        V(0x1017, _uint("Producer heartbeat time", UNSIGNED16, "rw", 100, 0, 0xFFFF, description="ms")),
        Obj(0x1018, "Identity object", object_type=0x9, subs={
            0: _uint("Highest sub-index supported", UNSIGNED8, "const", 4),
            1: _uint("Vendor-ID", UNSIGNED32, "ro", 0, description="no CiA vendor-ID assigned"),
            2: _uint("Product code", UNSIGNED32, "ro", own),
            3: _uint("Revision number", UNSIGNED32, "ro", 0x00010000),
            4: _uint("Serial number", UNSIGNED32, "ro", 0)}),
        V(0x1019, _uint("Synchronous counter overflow value", UNSIGNED8, "rw", 240, 0, 240,
                        description="0 no counter, 2..240 counter wraps after this value")),
        _pdo_comm(0x1400, "RPDO1 communication parameter", f"0x{0x180 + peer:X}", 1, tpdo=False),
        _pdo_map(0x1600, "RPDO1 mapping parameter", [_mapping(0x2103, 0, 32), _mapping(0x2104, 0, 32)]),
        _pdo_comm(0x1401, "RPDO2 communication parameter", f"0x{CONTACT_PDO_BASE + peer:X}", 1, tpdo=False),
        _pdo_map(0x1601, "RPDO2 mapping parameter", _contact_pdo(0x2105, 0x2615, 0x2616, 0x2617, role == "master")),
        *([_pdo_comm(0x1402, "RPDO3 communication parameter", f"0x{IDENT_PDO_BASE + peer:X}", 255, tpdo=False),
           _pdo_map(0x1602, "RPDO3 mapping parameter", [_mapping(0x261B, 0, 32)])] if role == "master" else []),
        _pdo_comm(0x1800, "TPDO1 communication parameter", "$NODEID+0x180", 1, tpdo=True),
        _pdo_comm(0x1801, "TPDO2 communication parameter", "$NODEID+0x280", TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True),
        _pdo_comm(0x1802, "TPDO3 communication parameter", "$NODEID+0x380", TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True),
        _pdo_comm(0x1803, "TPDO4 communication parameter", "$NODEID+0x480", TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True),
        _pdo_comm(0x1804, "TPDO5 communication parameter", f"$NODEID+0x{CONTACT_PDO_BASE:X}", 1, tpdo=True),
        *([_pdo_comm(0x1805, "TPDO6 communication parameter", f"$NODEID+0x{IDENT_PDO_BASE:X}",
                     TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True)] if role == "slave" else []),
        _pdo_map(0x1A00, "TPDO1 mapping parameter", [_mapping(0x2100, 0, 32), _mapping(0x2001, 0, 32)]),
        _pdo_map(0x1A01, "TPDO2 mapping parameter", [_mapping(0x2000, 0, 32), _mapping(0x2002, 0, 32)]),
        _pdo_map(0x1A02, "TPDO3 mapping parameter", [_mapping(0x2101, 0, 32), _mapping(0x2102, 0, 32)]),
        _pdo_map(0x1A03, "TPDO4 mapping parameter", [_mapping(0x2702, 0, 32), _mapping(0x2700, 0, 8),
                                                     _mapping(0x2500, 0, 8), _mapping(0x2004, 0, 8),
                                                     _mapping(0x2705, 0, 8)]),
        _pdo_map(0x1A04, "TPDO5 mapping parameter", _contact_pdo(0x2006, 0x2610, 0x2614, 0x2611, role == "slave")),
        *([_pdo_map(0x1A05, "TPDO6 mapping parameter", [_mapping(0x261A, 0, 32)])] if role == "slave" else []),
    ]
    return objs


def _check_value(section: str, text: str) -> None:
    """A value every EDS reader takes: no ';' (an inline comment for canopen's parser), no line break,
    no '=' (canopen-monitor splits every line on '=' and crashes on a second one)."""
    if any(c in text for c in ";=\n"):
        raise ValueError(f"[{section}]: ';', '=' or a line break in {text!r} would break EDS readers")


def _var_lines(section: str, var: Var) -> list[str]:
    for text in (var.name, var.description, var.default, var.unit, var.low or "", var.high or ""):
        _check_value(section, text)
    lines = [f"[{section}]", f"ParameterName={var.name}", "ObjectType=0x7", f"DataType=0x{var.data_type:04X}",
             f"AccessType={var.access}", f"DefaultValue={var.default}", f"PDOMapping={int(var.pdo)}"]
    if var.low is not None:
        lines.append(f"LowLimit={var.low}")
    if var.high is not None:
        lines.append(f"HighLimit={var.high}")
    if var.unit:
        lines.append(f"Unit={var.unit}")
    if var.description:
        lines.append(f"Description={var.description}")
    return lines + [""]


def render(role: str) -> str:
    """The EDS text of ``role`` ("master" or "slave")."""
    if role not in NODE_IDS:
        raise ValueError(f"role must be one of {sorted(NODE_IDS)}, got {role!r}")
    comm, manu = communication_objects(role), manufacturer_objects(role)
    mandatory = [o for o in comm if o.index in (0x1000, 0x1001, 0x1018)]
    optional = [o for o in comm if o not in mandatory]
    n_rx = sum(1 for o in comm if 0x1400 <= o.index <= 0x15FF)
    n_tx = sum(1 for o in comm if 0x1800 <= o.index <= 0x19FF)
    out = [
        "[FileInfo]", f"FileName={role}.eds", "FileVersion=1", "FileRevision=0", "EDSVersion=4.0",
        f"Description=telethermo {role} node (bilateral thermal telepresence), generated by bus_config/edsgen.py",
        f"CreationTime={EDS_TIME}", f"CreationDate={EDS_DATE}", "CreatedBy=telethermo",
        f"ModificationTime={EDS_TIME}", f"ModificationDate={EDS_DATE}", "ModifiedBy=telethermo", "",
        "[DeviceInfo]", "VendorName=telethermo", "VendorNumber=0x00000000", f"ProductName=telethermo {role}",
        f"ProductNumber=0x{NODE_IDS[role]:08X}", "RevisionNumber=0x00010000", f"OrderCode=telethermo-{role}",
        *[f"BaudRate_{r}={int(r == 1000 or r == 500 or r == 250 or r == 125)}" for r in (10, 20, 50, 125, 250, 500, 800, 1000)],
        "SimpleBootUpMaster=0", "SimpleBootUpSlave=1", "Granularity=8", "DynamicChannelsSupported=0",
        "GroupMessaging=0", f"NrOfRXPDO={n_rx}", f"NrOfTXPDO={n_tx}", "LSS_Supported=0", "",
        "[DummyUsage]", *[f"Dummy{i:04d}=0" for i in range(1, 8)], "",
        "[Comments]", "Lines=2", "Line1=Manufacturer object names end in their unit (_C degC, _W, _A, _s, ...).",
        "Line2=REAL32 LowLimit/HighLimit are decimals, SDO writes outside them abort 0x06090030/31/32.", "",
    ]
    for title, objs in (("MandatoryObjects", mandatory), ("OptionalObjects", optional), ("ManufacturerObjects", manu)):
        out += [f"[{title}]", f"SupportedObjects={len(objs)}"]
        out += [f"{i}=0x{o.index:04X}" for i, o in enumerate(objs, 1)] + [""]
    for o in comm + manu:
        if o.var is not None:
            out += _var_lines(f"{o.index:04X}", o.var)
            continue
        out += [f"[{o.index:04X}]", f"ParameterName={o.name}", f"ObjectType=0x{o.object_type:X}",
                f"SubNumber=0x{len(o.subs):X}", ""]
        for sub, var in o.subs.items():
            out += _var_lines(f"{o.index:04X}sub{sub:X}", var)
    for line in out:   # every value of every section, the file's own keys included
        if "=" in line:
            _check_value(role, line.split("=", 1)[1])
    return "\n".join(out)


def markdown_table(role: str = "master") -> str:
    """The object dictionary as a Markdown table (for docs/canopen.md)."""
    types = {BOOLEAN: "BOOLEAN", UNSIGNED8: "U8", UNSIGNED16: "U16", UNSIGNED32: "U32", REAL32: "REAL32", REAL64: "REAL64",
             VISIBLE_STRING: "STRING", INTEGER16: "I16"}
    rows = ["| index | sub | name | type | access | default | range | unit | PDO |",
            "|---|---|---|---|---|---|---|---|---|"]

    def row(index, sub, var):
        rng = f"{var.low} .. {var.high}" if var.low is not None else ""
        rows.append(f"| 0x{index:04X} | {sub} | {var.name} | {types.get(var.data_type, hex(var.data_type))} | "
                    f"{var.access} | {var.default} | {rng} | {var.unit} | {'yes' if var.pdo else ''} |")

    for o in communication_objects(role) + manufacturer_objects(role):
        if o.var is not None:
            row(o.index, 0, o.var)
        elif o.index in (0x2310, 0x2311):
            first, last = o.subs[1], o.subs[len(o.subs) - 1]
            rows.append(f"| 0x{o.index:04X} | 1..{len(o.subs) - 1} | {o.name}: {first.name}..{last.name} | {types[first.data_type]} | "
                        f"{first.access} | {first.default} | {first.low} .. {first.high} | | |")
        else:
            for sub, var in o.subs.items():
                row(o.index, sub, var)
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:

    parser = argparse.ArgumentParser(description="Generate bus_config/master.eds and slave.eds.")
    parser.add_argument("--check", action="store_true", help="only compare; exit 1 if a file differs")
    parser.add_argument("--table", metavar="ROLE", help="print the object dictionary of ROLE as Markdown")
    args = parser.parse_args(argv)
    if args.table:
        print(markdown_table(args.table))
        return 0
    stale = []
    for role in NODE_IDS:
        target = Path(_path(f"{role}.eds"))
        text = render(role)
        if args.check:
            if not target.exists() or target.read_text(encoding="ascii") != text:
                stale.append(str(target))
        else:
            write_text_atomic(target, text)
    if stale:
        print("stale EDS (run python -m telethermo.bus_config.edsgen): " + ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
