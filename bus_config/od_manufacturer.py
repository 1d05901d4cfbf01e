"""The manufacturer-specific objects (0x2000..) of the two nodes' object dictionaries, in groups: measurements
and control, the TEM model, safety/mode/rendering/material identification, identification/status/diagnostics.
``bus_config/edsgen.py`` writes them into master.eds and slave.eds with the communication objects. The
operator parameters (gains, estimator, R_sensor, safety limits, mode, rendering, link loss, identification
plan) are rows of ``bus_config/partable.py``, inserted here by index (:func:`with_params`)."""
from __future__ import annotations

from typing import Any, Callable

from telethermo.bus_config.od_types import (BOOLEAN, UNSIGNED8, UNSIGNED16, UNSIGNED32, VISIBLE_STRING, Obj,
                                            Var, _real, _real64, _uint)
from telethermo.bus_config.partable import param_objects


def _measurement_and_control_objects(V: Callable[[int, Any], Obj], role: str) -> list[Obj]:
    """Measurements and estimates (the controller's gains, eq. 33-35: bus_config/partable.py)."""
    ro_pdo = dict(pdo=True)
    return [
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
    ]


def _model_objects(V: Callable[[int, Any], Obj], role: str) -> list[Obj]:
    """The TEM model's parameters (NARMA eq. 10, flux ARMA eq. 12)."""
    return [
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
    ]


def _safety_mode_render_objects(V: Callable[[int, Any], Obj], role: str) -> list[Obj]:
    """Safety envelope, mode, virtual rendering and its later phase, material identification."""
    return [
        # -- safety envelope (DESIGN.md section 6): its operator's reset (the limits: bus_config/partable.py)
        V(0x240A, _uint("fault_reset", UNSIGNED8, "rw", 0, 0, 1,
                        description="write 1: clear the latched trips whose cause is gone (refused with 0x08000022 "
                                    "while one persists: nothing cleared) (reads 0)")),
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
        V(0x2619, _uint("link_fallback_active", BOOLEAN, "ro", 0, pdo=True,
                        description="1 while the master renders the last identified material because the slave is "
                                    "lost (EMCY 0xFF01 when it starts)")),
        V(0x261A, _real("identified_T_object0_C", "ro", 0.0, pdo=True,
                        description="(slave) initial temperature of the last touched object, from the same fit "
                                    "(0 none), sent in TPDO6")),
        V(0x261B, _real("peer_identified_T_object0_C", "rww", 0.0, -273.15, 1000.0, pdo=True,
                        description="the slave's identified_T_object0_C, received in RPDO3 (master)")),
    ]


def _material_answer_objects(V: Callable[[int, Any], Obj], role: str) -> list[Obj]:
    """The answer that improves while the touch lasts (issue 23; material identification, after 0x261B): the
    first answer (0.3 s of contact, out about 0.44 s after it) stays in 0x261C/0x261D when identified_material
    and identified_posterior take the refined one (1.2 s window, out about 1.32 s after contact);
    identified_stage says which one they hold."""
    return [
        V(0x261C, _uint("identified_early_material", UNSIGNED8, "ro", 0, pdo=True,
                        description="(slave, in TPDO6) the last touch's first answer (0.3 s), coded as "
                                    "identified_material")),
        V(0x261D, _real("identified_early_posterior", "ro", 0.0,
                        description="(slave) posterior of identified_early_material (0 none or unknown)")),
        V(0x261E, _uint("identified_stage", UNSIGNED8, "ro", 0, pdo=True,
                        description="(slave, sent in TPDO6) which answer identified_material holds: 0 none, "
                                    "1 first, 2 refined")),
        V(0x261F, _uint("peer_identified_early_material", UNSIGNED8, "rww", 0, 0, 255, pdo=True,
                        description="the slave's identified_early_material, received in RPDO3 (master)")),
        V(0x2620, _uint("peer_identified_stage", UNSIGNED8, "rww", 0, 0, 2, pdo=True,
                        description="the slave's identified_stage, received in RPDO3 (master)")),
    ]


def _identification_status_objects(V: Callable[[int, Any], Obj], role: str) -> list[Obj]:
    """Identification experiment, status and device-layer diagnostics."""
    ro_pdo = dict(pdo=True)
    return [
        # -- identification experiment (IDENTIFY mode; telethermo.ident.plan.IdentifyPlan)
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
        V(0x2708, _uint("limits_active", UNSIGNED8, "ro", 0,
                        description="the envelope's limits that acted in the last cycle: bit 0 setpoint clamp (a "
                                    "target beyond the clamps saturates there), 1 ramp, 2 hot cap, 3 guard, 4 current "
                                    "limit, 5 neutral ramp, 6 cut, 7 slew")),
        # -- device-layer diagnostics (written by telethermo.device)
        V(0x2710, _uint("malformed_frames", UNSIGNED32, "ro", 0, description="frames with a wrong length, ignored")),
        V(0x2711, _uint("unknown_cobid_frames", UNSIGNED32, "ro", 0, description="frames with a COB-ID outside the contract")),
        V(0x2712, _uint("callback_errors", UNSIGNED32, "ro", 0, description="exceptions caught in application callbacks")),
        V(0x2713, _uint("sync_count", UNSIGNED32, "ro", 0, description="SYNC objects processed")),
        V(0x2714, _uint("rpdo_count", UNSIGNED32, "ro", 0, description="RPDOs accepted")),
        V(0x2715, _uint("peer_losses", UNSIGNED32, "ro", 0, description="heartbeat-consumer timeouts")),
        # -- parameter store (0x1010/0x1011, written by the node: telethermo.nodes.store_slot)
        V(0x2720, _uint("store_state", UNSIGNED8, "ro", 0,
                        description="0 no - defaults, 1 yes - restored at boot, 2 no - store file refused at "
                                    "boot, defaults, 3 yes - saved, 4 no - defaults from the next reset")),
        V(0x2721, _uint("store_saved_unix_s", UNSIGNED32, "ro", 0,
                        description="when the store in force was saved, s since 1970-01-01 UTC (0: none)")),
        V(0x2722, Var("store_file", VISIBLE_STRING, "ro", "-",
                      description="the node's store file (--store)")),
    ]


def with_params(objs: list[Obj], role: str) -> list[Obj]:
    """``objs`` with the operator parameters of bus_config/partable.py, each inserted before the first
    object of a higher index (the groups above are in index order, the status group after them)."""
    out = list(objs)
    for p in param_objects(role, 0x2000, 0x5FFF):
        out.insert(next((i for i, o in enumerate(out) if o.index > p.index), len(out)), p)
    return out


def manufacturer_objects(role: str = "master") -> list[Obj]:
    """0x2000..: measurements, estimates, gains, model, safety, mode, rendering, status, diagnostics."""
    V = lambda idx, var: Obj(idx, var.name, var=var)  # noqa: E731
    hand = [*_measurement_and_control_objects(V, role), *_model_objects(V, role),
            *_safety_mode_render_objects(V, role), *_material_answer_objects(V, role),
            *_identification_status_objects(V, role)]
    return with_params(hand, role)
