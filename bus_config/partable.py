"""The operator parameters on the bus, one row each: the one place a settable parameter is declared.

A row gives the object (index, name, CiA data type, access, PDO flag, range and default, per role where
the roles differ, unit), where its value lives in the control core's parameters (``field``: a path into
:class:`telethermo.control.core.CoreParams`, with ``convert`` naming the rare non-identity mapping) and
the scope it applies to; its one line of documentation is in :data:`DOCS`, by name (so that a row stays
one to three lines once formatted). From these rows come:

- the parameter objects of both object dictionaries (merged with ``bus_config/objtable.py`` by
  ``bus_config/od_manufacturer.py``, hence the EDS files written by
  ``python -m telethermo.bus_config.edsgen``);
- the mapping between the objects and CoreParams (``nodes/odparams.py``: what an SDO write changes, what
  ``telethermo get`` shows, what a CiA 301 store saves);
- the parameter table of the docs (``docs/parameters.md``).

``python -m telethermo.bus_config.edsgen`` writes the EDS files and the docs tables from it; ``--check``
exits 1 when one of them is stale.

Adding a parameter: one row and its line in :data:`DOCS` here (and the code that uses its field).
Measured values, status, commands (``fault_reset``, ``model_command``) and the TEM model's objects are not
operator parameters: they are the rows of ``bus_config/objtable.py``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Union

from telethermo.bus_config.od_types import (
    BOOLEAN,
    REAL32,
    UNSIGNED8,
    UNSIGNED16,
    UNSIGNED32,
    Obj,
    Var,
    _real,
    _uint,
)

ROLES = ("master", "slave")
Num = Union[int, float]
#: a value that differs per role: {"master": ..., "slave": ...}
PerRole = Union[Num, dict[str, Num]]

# scopes: which parameters a written value changes
GAINS = "per mode"  # each mode keeps its own value (the mode in force when it was written)
ALL = "all modes"
RENDER = "RENDER"  # the rendering settings (used in RENDER, shown in every mode)
IDENTIFY = "IDENTIFY"  # the identification experiment's plan (fixed while it runs)
NODE = "node"  # the node program's, not the control core's (mode, peer link)

# converters (``convert``): how an object's value maps to its field(s), beyond "the same number"
ESTIMATOR_CODE = "estimator code"  # 0 MODEL, 1 FLUX, 2 FUSED
FRACTION_OF_I_MAX = "fraction of I_max"  # object A = field x safety.I_max_A
SMALLEST = "smallest"  # one object sets several fields; shown: the smallest
LOW_END, HIGH_END = "low end", "high end"  # one end of a (low, high) field

TYPE_NAMES = {
    BOOLEAN: "BOOLEAN",
    UNSIGNED8: "UNSIGNED8",
    UNSIGNED16: "UNSIGNED16",
    UNSIGNED32: "UNSIGNED32",
    REAL32: "REAL32",
}


@dataclass(frozen=True)
class Param:
    """One operator parameter: its object and its field in the control core's parameters."""

    index: int
    name: str
    data_type: int
    default: PerRole
    low: PerRole
    high: PerRole
    unit: str
    field: tuple[str, ...]
    """CoreParams paths ("safety.T_min_C", "identify.amplitude_A"); () when the node holds it."""
    scope: str
    doc: str
    convert: str = ""
    access: str = "rw"
    pdo: bool = False
    stored: bool = True
    """Saved by a CiA 301 store (0x1010) and restored at power-on."""

    def value(self, what: str, role: str) -> Num:
        """``default``, ``low`` or ``high`` of ``role``."""
        v = getattr(self, what)
        return v[role] if isinstance(v, dict) else v

    def var(self, role: str) -> Var:
        """The object dictionary entry of ``role``."""
        d, lo, hi = (self.value(w, role) for w in ("default", "low", "high"))
        if self.data_type == REAL32:
            v = _real(self.name, self.access, d, lo, hi, pdo=self.pdo, description=self.doc)
        else:
            v = _uint(self.name, self.data_type, self.access, d, lo, hi, pdo=self.pdo, description=self.doc)
        return Var(v.name, v.data_type, v.access, v.default, v.low, v.high, v.pdo, v.description, self.unit)

    @property
    def is_real(self) -> bool:
        return self.data_type == REAL32


def _P(
    index: int,
    name: str,
    data_type: int,
    default: PerRole,
    low: PerRole,
    high: PerRole,
    unit: str,
    field: str | tuple[str, ...],
    scope: str,
    convert: str = "",
    pdo: bool = False,
    stored: bool = True,
) -> Param:
    """A row; its documentation is ``DOCS[name]``."""
    fields = (field,) if isinstance(field, str) else field
    return Param(
        index,
        name,
        data_type,
        default,
        low,
        high,
        unit,
        fields,
        scope,
        DOCS[name],
        convert=convert,
        pdo=pdo,
        stored=stored,
    )


# the master's envelope guards skin, the slave's the probe's hardware (telethermo.control.safety_limits)
_LO, _HI = {"master": 15.0, "slave": 0.0}, {"master": 43.0, "slave": 60.0}
_HOT = {"master": 41.0, "slave": 58.0}
# the oscillation guard's threshold, degC (0: off): the slave's guard; the master's stays off
_GUARD, _GUARD_HI = {"master": 0.0, "slave": 0.15}, {"master": 0.0, "slave": 1.0}
_EST_DOC = (
    "eq. 30/31, 2*T_sensor - T_pred, with T_pred from: 0 the NARMA model (eq. 32), "
    "1 the flux sensor, T1 of eq. 28 as T_sensor + Q*R_sensor/2 (default), 2 both fused "
    "(0 and 2 need a loaded model: model_status 1)"
)

#: one line of documentation per parameter (the EDS Description= key and docs/parameters.md)
DOCS: dict[str, str] = {
    "kp_A_per_C": "proportional gain",
    "ki_A_per_C_s": "integral gain",
    "kQ_A_per_W": "heat-flux feed-forward gain (peer's flux)",
    "estimator": _EST_DOC,
    "osc_guard_C": (
        "(slave) oscillation guard: two half-cycles in a row of the received finger estimate's 0.3-5 Hz "
        "band, each peaking at least this high in settled contact, quarter the probe's kp in contact (0: "
        "off, the master's is always off)"
    ),
    "R_sensor_C_per_W": "flux-sensor thermal resistance e/(kS), eq. 29",
    "T_min_C": (
        "lowest surface setpoint, must not exceed neutral_C and must stay more than 1 degC (two 0.5 degC "
        "guard bands) below T_max_C"
    ),
    "T_max_C": (
        "highest surface setpoint, must not be below neutral_C and must stay more than 1 degC (two 0.5 degC"
        " guard bands) above T_min_C"
    ),
    "ramp_limit_C_per_s": "setpoint ramp limit",
    "hot_threshold_C": "time-at-temperature threshold",
    "hot_time_limit_s": "longest time above hot_threshold_C",
    "current_limit_A": (
        "current limit, at most 0.8 Imax of the rig (the node writes its own: 2.4 A on the simulated 3 A rig)"
    ),
    "sink_trip_C": "heat-sink trip temperature",
    "neutral_C": "neutral temperature on peer loss, must lie within [T_min_C, T_max_C]",
    "peer_pdo_miss_limit": "missed peer PDOs (cycles) before peer loss",
    "mismatch_limit_C": "model-vs-sensor plausibility limit",
    "mismatch_time_s": (
        "how long the model-vs-sensor mismatch must exceed mismatch_limit_C before it cuts the current"
    ),
    "mode": "0 idle, 1 telepresence, 2 render, 3 identify (render on the master only)",
    "material_code": (
        "0 custom (material_beta), k from 1: the k-th material of the rendering table "
        "(telethermo/data/render_materials.toml, in file order)"
    ),
    "material_beta": "relative effusivity of the object (eq. 6)",
    "object_T0_C": "initial object temperature",
    "finger_T0_C": "initial finger temperature",
    "pad_beta": "relative effusivity of the pad",
    "later_model": (
        "after the first instant: 0 semi-infinite (eq. 1 for the whole touch), 1 RC (benali-khoudja 4), 2 "
        "conduction model of the object (1 and 2 need a material of telethermo/data/render_objects.toml)"
    ),
    "object_thickness_mm": "virtual object thickness, mm",
    "object_back": "virtual object back face: 0 adiabatic, 1 losing to ambient air",
    "link_loss_render_s": (
        "(master, telepresence) slave lost while the operator touches an identified material: render it "
        "locally this long before the ramp to neutral (0: at once)"
    ),
    "ident_seed": "PRBS seed (held-out: seed + 1)",
    "ident_rest_samples": "samples at 0 A first",
    "ident_train_samples": "training PRBS samples",
    "ident_validation_samples": "held-out PRBS samples",
    "ident_amplitude_min_A": (
        "smallest PRBS bit amplitude, must not exceed ident_amplitude_max_A nor change while identifying "
        "(mode 3)"
    ),
    "ident_amplitude_max_A": (
        "largest PRBS bit amplitude, must not be below ident_amplitude_min_A nor change while identifying "
        "(mode 3)"
    ),
    "ident_hold_samples": "samples per PRBS bit",
}

#: every operator parameter, in index order. Power-on gains are neutral placeholders: a node writes its
#: controller's parameters (telethermo/control/defaults.py, read at run time) over them before it starts.
PARAMS: tuple[Param, ...] = (
    # -- controller (eq. 33-35)
    _P(0x2200, "kp_A_per_C", REAL32, 0.5, 0.0, 20.0, "A/degC", "kp_A_per_C", GAINS),
    _P(0x2201, "ki_A_per_C_s", REAL32, 0.1, 0.0, 20.0, "A/(degC*s)", "ki_A_per_C_s", GAINS),
    _P(0x2202, "kQ_A_per_W", REAL32, 0.0, -20.0, 20.0, "A/W", "kQ_A_per_W", GAINS),
    _P(0x2203, "estimator", UNSIGNED8, 0, 0, 2, "", "estimator", ALL, convert=ESTIMATOR_CODE),
    # -- the slave's oscillation guard (issue 22; telethermo.control.osc_guard); the master runs none
    _P(0x2204, "osc_guard_C", REAL32, _GUARD, 0.0, _GUARD_HI, "degC", "osc_guard_C", ALL),
    # -- flux sensor (eq. 29)
    _P(0x2309, "R_sensor_C_per_W", REAL32, 2.0, 0.0, 1000.0, "degC/W", "R_sensor_K_per_W", ALL),
    # -- safety envelope (DESIGN.md section 6): ranges only allow narrowing the defaults
    _P(0x2400, "T_min_C", REAL32, _LO, _LO, _HI, "degC", "safety.T_min_C", ALL),
    _P(0x2401, "T_max_C", REAL32, _HI, _LO, _HI, "degC", "safety.T_max_C", ALL),
    _P(
        0x2402,
        "ramp_limit_C_per_s",
        REAL32,
        5.0,
        0.01,
        5.0,
        "degC/s",
        ("safety.ramp_up_C_per_s", "safety.ramp_down_C_per_s"),
        ALL,
        convert=SMALLEST,
    ),
    _P(0x2403, "hot_threshold_C", REAL32, _HOT, 30.0, _HI, "degC", "safety.hot_C", ALL),
    _P(
        0x2404,
        "hot_time_limit_s",
        REAL32,
        {"master": 30.0, "slave": 600.0},
        0.0,
        600.0,
        "s",
        "safety.hot_time_limit_s",
        ALL,
    ),
    _P(
        0x2405,
        "current_limit_A",
        REAL32,
        1.6,
        0.0,
        10.0,
        "A",
        "safety.current_fraction",
        ALL,
        convert=FRACTION_OF_I_MAX,
    ),
    _P(0x2406, "sink_trip_C", REAL32, 55.0, 20.0, 55.0, "degC", "safety.sink_trip_C", ALL),
    _P(0x2407, "neutral_C", REAL32, 32.0, 28.0, 36.0, "degC", "safety.neutral_C", ALL),
    _P(0x2408, "peer_pdo_miss_limit", UNSIGNED16, 10, 1, 1000, "", (), NODE),
    _P(0x2409, "mismatch_limit_C", REAL32, 12.0, 0.1, 20.0, "degC", "safety.mismatch_C", ALL),
    _P(0x240B, "mismatch_time_s", REAL32, 1.0, 0.01, 1.0, "s", "safety.mismatch_time_s", ALL),
    # -- mode (telethermo.control.types.Mode)
    _P(0x2500, "mode", UNSIGNED8, 0, 0, 3, "", "mode", NODE, pdo=True, stored=False),
    # -- virtual rendering (yamamoto eq. 5/7)
    _P(0x2600, "material_code", UNSIGNED8, 0, 0, 255, "", "render.material", RENDER),
    _P(0x2601, "material_beta", REAL32, 1.0, 0.001, 1000.0, "", "render.beta_object", RENDER),
    _P(0x2602, "object_T0_C", REAL32, 25.0, -20.0, 100.0, "degC", "render.T_object0_C", RENDER),
    _P(0x2603, "finger_T0_C", REAL32, 33.0, 20.0, 40.0, "degC", "render.T_finger0_C", RENDER),
    _P(0x2604, "pad_beta", REAL32, 1.0, 0.001, 1000.0, "", "render.beta_pad", RENDER),
    # -- later phase of a rendered touch (issue 15; telethermo.control.later_phase)
    _P(0x2605, "later_model", UNSIGNED8, 0, 0, 2, "", "render.later", RENDER),
    _P(0x2606, "object_thickness_mm", REAL32, 20.0, 0.01, 1000.0, "mm", "render.later", RENDER),
    _P(0x2607, "object_back", UNSIGNED8, 0, 0, 1, "", "render.later", RENDER),
    # -- graceful link loss (issue 15; telethermo.control.link_fallback)
    _P(0x2618, "link_loss_render_s", REAL32, 5.0, 0.0, 60.0, "s", "link_loss_render_s", ALL),
    # -- identification experiment (IDENTIFY mode; telethermo.ident.plan.IdentifyPlan)
    _P(0x2800, "ident_seed", UNSIGNED16, 0, 0, 0xFFFF, "", "identify.seed", IDENTIFY),
    _P(0x2801, "ident_rest_samples", UNSIGNED32, 200, 0, 100_000, "", "identify.rest_samples", IDENTIFY),
    _P(0x2802, "ident_train_samples", UNSIGNED32, 10_000, 1, 500_000, "", "identify.train_samples", IDENTIFY),
    _P(
        0x2803,
        "ident_validation_samples",
        UNSIGNED32,
        5_000,
        1,
        500_000,
        "",
        "identify.validation_samples",
        IDENTIFY,
    ),
    _P(
        0x2804,
        "ident_amplitude_min_A",
        REAL32,
        0.1,
        0.0,
        10.0,
        "A",
        "identify.amplitude_A",
        IDENTIFY,
        convert=LOW_END,
    ),
    _P(
        0x2805,
        "ident_amplitude_max_A",
        REAL32,
        1.0,
        0.0,
        10.0,
        "A",
        "identify.amplitude_A",
        IDENTIFY,
        convert=HIGH_END,
    ),
    _P(0x2806, "ident_hold_samples", UNSIGNED16, 25, 1, 10_000, "", "identify.hold_samples", IDENTIFY),
)
BY_NAME: dict[str, Param] = {p.name: p for p in PARAMS}


def param_objects(role: str, first: int, last: int) -> list[Obj]:
    """The object dictionary objects of the parameters with ``first <= index <= last``, in index order."""
    return [Obj(p.index, p.name, var=p.var(role)) for p in PARAMS if first <= p.index <= last]


def _fmt(v: Num) -> str:
    return repr(float(v)) if isinstance(v, float) else str(v)


def _per_role(p: Param, what: str) -> str:
    m, s = (p.value(what, r) for r in ROLES)
    return _fmt(m) if m == s else f"{_fmt(m)} (master), {_fmt(s)} (slave)"


def markdown() -> str:
    """docs/parameters.md: the table of every operator parameter."""
    head = [
        "# Operator parameters",
        "",
        "Generated from `bus_config/partable.py` by `python -m telethermo.bus_config.edsgen`: "
        "do not edit "
        "by hand (`tests/bus_config/test_partable.py` fails when this page, the EDS files and the table "
        "disagree). Every parameter is `rw` by SDO and shown by `telethermo get`; stored: saved by a "
        "CiA 301 store (0x1010, `telethermo save`); scope: which of the controller's parameters a write "
        "changes (the master's envelope guards skin, the slave's the probe's hardware).",
        "",
        "| index | name | type | default | range | unit | CoreParams field | scope | stored | what |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    rows = []
    for p in PARAMS:
        field = ", ".join(f"`{f}`" for f in p.field) or "(node)"
        if p.convert:
            field += f" ({p.convert})"
        rng = f"{_per_role(p, 'low')} .. {_per_role(p, 'high')}"
        rows.append(
            f"| 0x{p.index:04X} | {p.name} | {TYPE_NAMES[p.data_type]} | {_per_role(p, 'default')} | "
            f"{rng} | {p.unit} | {field} | {p.scope} | {'yes' if p.stored else 'no'} | {p.doc} |"
        )
    return "\n".join(head + rows) + "\n"


#: the generated page (in a checkout; ``python -m telethermo.bus_config.edsgen`` writes it with the EDS files)
DOC = Path(__file__).resolve().parents[1] / "docs" / "parameters.md"
