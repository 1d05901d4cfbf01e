"""The manufacturer objects 0x2000..0x2311 of the two nodes: measurements and estimates (the
controller's gains, eq. 33-35: bus_config/partable.py) and the TEM model (NARMA eq. 10, flux ARMA eq. 12).
Composed by :func:`telethermo.bus_config.od_manufacturer.manufacturer_objects`."""

from __future__ import annotations

from typing import Any, Callable

from telethermo.bus_config.od_types import (
    BOOLEAN,
    UNSIGNED8,
    UNSIGNED32,
    Obj,
    _real,
    _real64,
    _uint,
)


def objects_2000_2102(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x2000..0x2102. Measurements and estimates (the controller's gains, eq. 33-35:
    bus_config/partable.py)."""
    ro_pdo = dict(pdo=True)
    return [
        # -- measurements (written by the node from its rig each cycle; read-only on the bus)
        V(
            0x2000,
            _real(
                "T_sensor_C", "ro", 0.0, **ro_pdo, description="flux-sensor mid-plane thermocouple, filtered"
            ),
        ),
        V(
            0x2001,
            _real(
                "Q_W",
                "ro",
                0.0,
                **ro_pdo,
                description="heat flux out of the pad into what touches it (>0 warms it)",
            ),
        ),
        V(
            0x2002,
            _real("current_A", "ro", 0.0, **ro_pdo, description="measured TEM current (>0 heats the pad)"),
        ),
        V(0x2003, _real("T_sink_C", "ro", 0.0, **ro_pdo, description="heat-sink temperature")),
        V(
            0x2004,
            _uint("contact", BOOLEAN, "ro", 0, **ro_pdo, description="contact detector: 1 while touched"),
        ),
        V(0x2005, _real("force_N", "ro", 0.0, **ro_pdo, description="contact force (0 if not measured)")),
        V(
            0x2006,
            _uint(
                "contact_decision",
                BOOLEAN,
                "ro",
                0,
                **ro_pdo,
                description="the controller's contact decision (its detector, or the rig's flag), sent in "
                "TPDO5",
            ),
        ),
        # -- estimates
        V(
            0x2100,
            _real(
                "estimate_C",
                "ro",
                0.0,
                **ro_pdo,
                description="own estimate sent in TPDO1: finger T_f (master, eq. 30) / object T_o (slave, "
                "eq. 31)",
            ),
        ),
        V(
            0x2101,
            _real(
                "T_pred_C",
                "ro",
                0.0,
                **ro_pdo,
                description="TEM surface temperature predicted by the model (eq. 32)",
            ),
        ),
        V(
            0x2102,
            _real(
                "T_cmd_C", "ro", 0.0, **ro_pdo, description="temperature command after the safety envelope"
            ),
        ),
    ]


def objects_2103_2105(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x2103..0x2105, continued: Measurements and estimates (the controller's gains, eq. 33-35:
    bus_config/partable.py)."""
    return [
        V(
            0x2103,
            _real(
                "peer_estimate_C",
                "rww",
                0.0,
                -273.15,
                1000.0,
                pdo=True,
                description="peer's estimate, received in RPDO1 (limits apply to SDO writes only)",
            ),
        ),
        V(
            0x2104,
            _real(
                "peer_Q_W",
                "rww",
                0.0,
                -1000.0,
                1000.0,
                pdo=True,
                description="peer's heat flux, received in RPDO1 (limits apply to SDO writes only)",
            ),
        ),
        V(
            0x2105,
            _uint(
                "peer_contact",
                BOOLEAN,
                "rww",
                0,
                0,
                1,
                pdo=True,
                description="peer's contact detector, received in RPDO2 (the probe touches something)",
            ),
        ),
    ]


def objects_2300_230c(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x2300..0x230C. The TEM model's parameters (NARMA eq. 10, flux ARMA eq. 12)."""
    return [
        # -- model parameters (NARMA eq. 10, flux ARMA eq. 12)
        V(0x2300, _uint("narma_n", UNSIGNED8, "rw", 3, 0, 8, description="output lags n")),
        V(0x2301, _uint("narma_m", UNSIGNED8, "rw", 3, 0, 8, description="input lags m")),
        V(0x2302, _uint("narma_p", UNSIGNED8, "rw", 3, 0, 4, description="polynomial order p of a_i in I")),
        V(0x2303, _uint("narma_q", UNSIGNED8, "rw", 3, 0, 4, description="polynomial order q of b_j in I")),
        V(
            0x2304,
            _real(
                "model_period_s",
                "rw",
                0.01,
                0.0005,
                1.0,
                description="sample period the model was identified at",
            ),
        ),
        V(
            0x2305,
            _real("model_T_ref_C", "rw", 25.0, -20.0, 80.0, description="reference temperature of the model"),
        ),
        V(
            0x2306,
            _uint("theta_len", UNSIGNED8, "rw", 0, 0, 48, description="number of valid entries of theta"),
        ),
        V(0x2307, _uint("flux_n", UNSIGNED8, "rw", 0, 0, 8, description="flux model order n (c_1..c_n)")),
        V(0x2308, _uint("flux_m", UNSIGNED8, "rw", 0, 0, 7, description="flux model order m (d_0..d_m)")),
        V(
            0x230A,
            _real64(
                "model_I_min_A",
                "rw",
                -1.0,
                -10.0,
                10.0,
                description="lowest current of the model's training data (stability is checked over the "
                "range)",
            ),
        ),
        V(
            0x230B,
            _real64(
                "model_I_max_A",
                "rw",
                1.0,
                -10.0,
                10.0,
                description="highest current of the model's training data",
            ),
        ),
        V(
            0x230C,
            _uint(
                "flux_with_current",
                BOOLEAN,
                "rw",
                0,
                0,
                1,
                description="1: flux_coeffs also hold e_1..e_m, g_1..g_m, h_1..h_m (current terms)",
            ),
        ),
    ]


def objects_230d_2311(V: Callable[[int, Any], Obj]) -> list[Obj]:
    """0x230D..0x2311, continued: The TEM model's parameters (NARMA eq. 10, flux ARMA eq. 12)."""
    return [
        V(
            0x230D,
            _uint(
                "model_command",
                UNSIGNED8,
                "rw",
                0,
                0,
                2,
                description="write 1: load the model held in 0x2300..0x2311 (refused with 0x08000020 if it "
                "is "
                "inconsistent or unstable), 2: unload it (reads 0)",
            ),
        ),
        V(
            0x230E,
            _uint(
                "model_status",
                UNSIGNED8,
                "ro",
                0,
                description="0 no model, 1 loaded (the objects hold the running model), 2 edited since "
                "loaded",
            ),
        ),
        V(
            0x230F,
            _uint(
                "model_crc32",
                UNSIGNED32,
                "ro",
                0,
                description="CRC-32 of the running model's objects (telethermo.ident.odmodel.od_crc32), 0 "
                "none",
            ),
        ),
        Obj(
            0x2310,
            "theta",
            object_type=0x8,
            subs={
                0: _uint("Highest sub-index supported", UNSIGNED8, "const", 48),
                **{
                    i: _real64(
                        f"theta{i}", "rw", 0.0, -1.0e6, 1.0e6, description="NARMA parameter (eq. 11 order)"
                    )
                    for i in range(1, 49)
                },
            },
        ),
        Obj(
            0x2311,
            "flux_coeffs",
            object_type=0x8,
            subs={
                0: _uint("Highest sub-index supported", UNSIGNED8, "const", 16),
                **{
                    i: _real64(
                        f"flux_coeff{i}",
                        "rw",
                        0.0,
                        -1.0e6,
                        1.0e6,
                        description="c_1..c_n, d_0..d_m (eq. 12), then e, g, h if flux_with_current",
                    )
                    for i in range(1, 17)
                },
            },
        ),
    ]
