"""The manufacturer objects 0x240A..0x2722 of the two nodes: the safety envelope's reset, material
identification and its answers, graceful link loss, the identification experiment, status, device-layer
diagnostics and the parameter store. Composed by
:func:`telethermo.bus_config.od_manufacturer.manufacturer_objects`."""

from __future__ import annotations

from typing import Any, Callable

from telethermo.bus_config.od_types import (
    BOOLEAN,
    UNSIGNED8,
    UNSIGNED16,
    UNSIGNED32,
    VISIBLE_STRING,
    Obj,
    Var,
    _real,
    _uint,
)


def objects_240a_2615(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x240A..0x2615. Safety envelope, mode, virtual rendering and its later phase, material
    identification."""
    return [
        # -- safety envelope (DESIGN.md section 6): its operator's reset (the limits: bus_config/partable.py)
        V(
            0x240A,
            _uint(
                "fault_reset",
                UNSIGNED8,
                "rw",
                0,
                0,
                1,
                description="write 1: clear the latched trips whose cause is gone (refused with 0x08000022 "
                "while one persists: nothing cleared) (reads 0)",
            ),
        ),
        # -- material identification (slave; written by the node from telethermo.control.material_stream)
        V(
            0x2610,
            _uint(
                "identified_material",
                UNSIGNED8,
                "ro",
                0,
                pdo=True,
                description="material of the last touch (its first 0.3 s): code in the rendering table as "
                "material_code, 0 none (no estimate, or the master)",
            ),
        ),
        V(
            0x2611,
            _real(
                "identified_beta",
                "ro",
                0.0,
                pdo=True,
                description="relative effusivity b/b_skin of the last touched object, as material_beta "
                "(b_skin 951 W*s^0.5/(m2*K) as in the rendering table, 0 none)",
            ),
        ),
        V(
            0x2612,
            _real(
                "identified_se_ln_b",
                "ro",
                0.0,
                description="standard error of ln(effusivity), about its relative error (0 none)",
            ),
        ),
        V(0x2613, _real("identified_posterior", "ro", 0.0, description="posterior of identified_material")),
        V(
            0x2614,
            _uint(
                "identified_touches", UNSIGNED16, "ro", 0, pdo=True, description="touches evaluated (wraps)"
            ),
        ),
        # -- graceful link loss (issue 15; telethermo.control.link_fallback): the slave's identification,
        # received by the master in RPDO2 with the contact flag (the slave's TPDO5), and the master's fallback
        V(
            0x2615,
            _uint(
                "peer_identified_material",
                UNSIGNED8,
                "rww",
                0,
                0,
                255,
                pdo=True,
                description="the slave's identified_material, received in RPDO2 (master)",
            ),
        ),
    ]


def objects_2616_261b(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x2616..0x261B, continued: Safety envelope, mode, virtual rendering and its later phase, material
    identification."""
    return [
        V(
            0x2616,
            _uint(
                "peer_identified_touches",
                UNSIGNED16,
                "rww",
                0,
                0,
                0xFFFF,
                pdo=True,
                description="the slave's identified_touches, received in RPDO2 (a change: a new "
                "identification)",
            ),
        ),
        V(
            0x2617,
            _real(
                "peer_identified_beta",
                "rww",
                0.0,
                -1.0e6,
                1.0e6,
                pdo=True,
                description="the slave's identified_beta, received in RPDO2 (limits apply to SDO writes "
                "only)",
            ),
        ),
        V(
            0x2619,
            _uint(
                "link_fallback_active",
                BOOLEAN,
                "ro",
                0,
                pdo=True,
                description="1 while the master renders the last identified material because the slave is "
                "lost (EMCY 0xFF01 when it starts)",
            ),
        ),
        V(
            0x261A,
            _real(
                "identified_T_object0_C",
                "ro",
                0.0,
                pdo=True,
                description="(slave) initial temperature of the last touched object, from the same fit "
                "(0 none), sent in TPDO6",
            ),
        ),
        V(
            0x261B,
            _real(
                "peer_identified_T_object0_C",
                "rww",
                0.0,
                -273.15,
                1000.0,
                pdo=True,
                description="the slave's identified_T_object0_C, received in RPDO3 (master)",
            ),
        ),
    ]


def objects_261c_2620(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x261C..0x2620. The answer that improves while the touch lasts (issue 23; material identification,
    after 0x261B): the first answer (0.3 s of contact, out about 0.44 s after it) stays in 0x261C/0x261D
    when identified_material and identified_posterior take the refined one (1.2 s window, out about 1.32 s
    after contact); identified_stage says which one they hold."""
    return [
        V(
            0x261C,
            _uint(
                "identified_early_material",
                UNSIGNED8,
                "ro",
                0,
                pdo=True,
                description="(slave, in TPDO6) the last touch's first answer (0.3 s), coded as "
                "identified_material",
            ),
        ),
        V(
            0x261D,
            _real(
                "identified_early_posterior",
                "ro",
                0.0,
                description="(slave) posterior of identified_early_material (0 none or unknown)",
            ),
        ),
        V(
            0x261E,
            _uint(
                "identified_stage",
                UNSIGNED8,
                "ro",
                0,
                pdo=True,
                description="(slave, sent in TPDO6) which answer identified_material holds: 0 none, "
                "1 first, 2 refined",
            ),
        ),
        V(
            0x261F,
            _uint(
                "peer_identified_early_material",
                UNSIGNED8,
                "rww",
                0,
                0,
                255,
                pdo=True,
                description="the slave's identified_early_material, received in RPDO3 (master)",
            ),
        ),
        V(
            0x2620,
            _uint(
                "peer_identified_stage",
                UNSIGNED8,
                "rww",
                0,
                0,
                2,
                pdo=True,
                description="the slave's identified_stage, received in RPDO3 (master)",
            ),
        ),
    ]


def objects_2807_280e(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x2807..0x280E. Identification experiment, status and device-layer diagnostics."""
    return [
        # -- identification experiment (IDENTIFY mode; telethermo.ident.plan.IdentifyPlan)
        V(
            0x2807,
            _uint(
                "ident_sample",
                UNSIGNED32,
                "ro",
                0,
                pdo=True,
                description="sample j of the experiment is sent with j + 1 (values above the plan's total: "
                "done, 0 A held)",
            ),
        ),
        V(
            0x2808,
            _uint(
                "ident_state",
                UNSIGNED8,
                "ro",
                0,
                pdo=True,
                description="0 not run, 1 running, 2 done, 3 interrupted (the mode changed before the end)",
            ),
        ),
        V(
            0x2809,
            _uint(
                "ident_guard",
                UNSIGNED32,
                "ro",
                0,
                description="samples whose current the guard flipped or cut",
            ),
        ),
        V(
            0x280A,
            _uint(
                "ident_start_cycle",
                UNSIGNED32,
                "ro",
                0,
                description="control cycles run before the experiment's first sample",
            ),
        ),
        V(
            0x280B,
            _uint(
                "ident_fetch_sample",
                UNSIGNED32,
                "rw",
                0,
                0,
                1_000_000,
                description="write j: sample j of the last experiment into 0x280C..0x280E (a sample lost on "
                "the bus is fetched again by SDO) (no such sample: abort 0x08000024)",
            ),
        ),
        V(
            0x280C,
            _real("ident_fetched_T_sensor_C", "ro", 0.0, description="T_sensor_C of the fetched sample"),
        ),
        V(
            0x280D,
            _real(
                "ident_fetched_current_A",
                "ro",
                0.0,
                description="current_A commanded after the fetched sample",
            ),
        ),
        V(0x280E, _real("ident_fetched_Q_W", "ro", 0.0, description="Q_W of the fetched sample")),
    ]


def objects_2700_2707(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x2700..0x2707, continued: Identification experiment, status and device-layer diagnostics."""
    ro_pdo = dict(pdo=True)
    return [
        # -- status (written by the node)
        V(
            0x2700,
            _uint(
                "safety_state",
                UNSIGNED8,
                "ro",
                0,
                **ro_pdo,
                description="0 ok, 1 limiting, 2 ramp to neutral, 3 current cut",
            ),
        ),
        V(
            0x2701,
            _uint(
                "last_trip_code",
                UNSIGNED16,
                "ro",
                0,
                **ro_pdo,
                description="EMCY code of the last trip (0 none)",
            ),
        ),
        V(0x2702, _uint("cycle_counter", UNSIGNED32, "ro", 0, **ro_pdo, description="control cycles run")),
        V(
            0x2703,
            _uint(
                "late_cycles",
                UNSIGNED32,
                "ro",
                0,
                **ro_pdo,
                description="real-time cycles that missed their slot",
            ),
        ),
        V(0x2704, _uint("lockstep", BOOLEAN, "ro", 0, **ro_pdo, description="1 lockstep, 0 real time")),
        V(
            0x2705,
            _uint(
                "peer_alive", BOOLEAN, "ro", 0, **ro_pdo, description="1 while the peer's heartbeat is seen"
            ),
        ),
        V(
            0x2706,
            _uint(
                "active_trips",
                UNSIGNED16,
                "ro",
                0,
                **ro_pdo,
                description="latched safety trips, bit i: the i-th trip of telethermo.control.safety.Trip "
                "(0x080 heat_sink, 0x200 peer_lost, ...)",
            ),
        ),
        V(
            0x2707,
            _uint(
                "fault_reset_blocked_by",
                UNSIGNED16,
                "ro",
                0,
                description="the trips whose cause persisted at the last refused fault reset (same bits)",
            ),
        ),
    ]


def objects_2708_2722(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x2708..0x2722, continued: Identification experiment, status and device-layer diagnostics."""
    return [
        V(
            0x2708,
            _uint(
                "limits_active",
                UNSIGNED8,
                "ro",
                0,
                description="the envelope's limits that acted in the last cycle: bit 0 setpoint clamp (a "
                "target beyond the clamps saturates there), 1 ramp, 2 hot cap, 3 guard, 4 current "
                "limit, 5 neutral ramp, 6 cut, 7 slew",
            ),
        ),
        # -- device-layer diagnostics (written by telethermo.device)
        V(
            0x2710,
            _uint("malformed_frames", UNSIGNED32, "ro", 0, description="frames with a wrong length, ignored"),
        ),
        V(
            0x2711,
            _uint(
                "unknown_cobid_frames",
                UNSIGNED32,
                "ro",
                0,
                description="frames with a COB-ID outside the contract",
            ),
        ),
        V(
            0x2712,
            _uint(
                "callback_errors",
                UNSIGNED32,
                "ro",
                0,
                description="exceptions caught in application callbacks",
            ),
        ),
        V(0x2713, _uint("sync_count", UNSIGNED32, "ro", 0, description="SYNC objects processed")),
        V(0x2714, _uint("rpdo_count", UNSIGNED32, "ro", 0, description="RPDOs accepted")),
        V(0x2715, _uint("peer_losses", UNSIGNED32, "ro", 0, description="heartbeat-consumer timeouts")),
        # -- parameter store (0x1010/0x1011, written by the node: telethermo.nodes.store_slot)
        V(
            0x2720,
            _uint(
                "store_state",
                UNSIGNED8,
                "ro",
                0,
                description="0 no - defaults, 1 yes - restored at boot, 2 no - store file refused at "
                "boot, defaults, 3 yes - saved, 4 no - defaults from the next reset",
            ),
        ),
        V(
            0x2721,
            _uint(
                "store_saved_unix_s",
                UNSIGNED32,
                "ro",
                0,
                description="when the store in force was saved, s since 1970-01-01 UTC (0: none)",
            ),
        ),
        V(
            0x2722,
            Var("store_file", VISIBLE_STRING, "ro", "-", description="the node's store file (--store)"),
        ),
    ]
