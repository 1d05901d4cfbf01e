"""Thermo-electric module (TEM) and the hardware parameters of one rig.

The TEM is lumped (guiatni §2.1): two ceramic plates (sink side ``s``, pad side ``p``) joined by the pellets'
conductance K. With the project's sign convention (current_A > 0 heats the pad plate), the heat delivered to
each plate by the electrical effects is (temperatures in K inside the Peltier term):

    u_p = +α·I·T_p + ½·R·I² + ½·τ·I·(T_p − T_s)      (pad plate)
    u_s = −α·I·T_s + ½·R·I² − ½·τ·I·(T_p − T_s)      (sink plate)

plus the conduction K·(T_s − T_p) between the plates. This is guiatni eq. 1–6: Peltier α·T·I (eq. 1) at each
junction with opposite signs, Joule R·I² (eq. 3) split half to each side, conduction (eq. 4), and the Thomson
term (eq. 2) integrated over the pellet, τ·I·ΔT/2 on each side with the sign of eq. 5/6's "±": "+" when I > 0
(pad is the hot side), "−" when I < 0. The electrical power is u_s + u_p = α·I·(T_p − T_s) + R·I².
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from telethermo.inputfile import ABSENT, Section, load_toml
from telethermo.sim.errors import SceneError
from telethermo.units import KELVIN

DATA_DIR = Path(__file__).resolve().parent / "data"
TEM_FILE = DATA_DIR / "tem_15x15.toml"


@dataclass(frozen=True, slots=True)
class TEMParams:
    """Lumped TEM parameters (whole module).

    Attributes:
        alpha_V_K: Seebeck coefficient, V/K.
        R_ohm: electrical resistance, Ω.
        K_W_K: thermal conductance between the plates, W/K.
        tau_V_K: Thomson coefficient integrated over the pellets, V/K (sign: see module docstring).
        plate_C_J_K: heat capacity of each plate, J/K.
        I_max_A: datasheet Imax, A (the drive's hard limit).
    """

    alpha_V_K: float
    R_ohm: float
    K_W_K: float
    tau_V_K: float
    plate_C_J_K: float
    I_max_A: float

    @staticmethod
    def from_datasheet(
        Imax_A: float,
        Vmax_V: float,
        dTmax_K: float,
        Th_C: float,
        *,
        tau_V_K: float = 0.0,
        plate_C_J_K: float = 0.62,
    ) -> "TEMParams":
        """Derive α, R, K from the datasheet ratings Imax, Vmax, ΔTmax at hot side Th (°C).

        Standard derivation (ideal module, Qc = 0 at ΔTmax): α = Vmax/Th, R = (Th − ΔTmax)·Vmax/(Th·Imax),
        K = (Th − ΔTmax)·Vmax·Imax/(2·Th·ΔTmax), with Th in K.
        """
        Th = Th_C + KELVIN
        alpha = Vmax_V / Th
        R = (Th - dTmax_K) * Vmax_V / (Th * Imax_A)
        K = (Th - dTmax_K) * Vmax_V * Imax_A / (2.0 * Th * dTmax_K)
        return TEMParams(alpha, R, K, tau_V_K, plate_C_J_K, Imax_A)

    def Qmax_W(self, Th_C: float) -> float:
        """Cooling capacity at ΔT = 0 and I = Imax implied by the derived parameters, W."""
        return self.alpha_V_K * (Th_C + KELVIN) * self.I_max_A - 0.5 * self.R_ohm * self.I_max_A**2

    def peak_cooling_current_A(self, T_cold_C: float) -> float:
        """The current at which the module cools its cold plate at ``T_cold_C`` (°C) the most, A:
        I* = α·T_c/R (guiatni eq. 5, the Peltier term against half the Joule term); more cooling current
        only heats.

        >>> round(TEMParams(0.05, 2.0, 0.5, 0.0, 0.62, 6.0).peak_cooling_current_A(15.0), 3)
        7.204
        """
        return float(self.alpha_V_K * (T_cold_C + KELVIN) / self.R_ohm)

    def plate_heat_W(self, I_A: float, T_s_C: float, T_p_C: float) -> tuple[float, float]:
        """Electrical heat (Peltier + Joule + Thomson) delivered to the (sink, pad) plates, W."""
        th = 0.5 * self.tau_V_K * I_A * (T_p_C - T_s_C)
        joule = 0.5 * self.R_ohm * I_A * I_A
        return (
            -self.alpha_V_K * I_A * (T_s_C + KELVIN) + joule - th,
            self.alpha_V_K * I_A * (T_p_C + KELVIN) + joule + th,
        )


def guiatni_capacities_W(p: TEMParams, I_A: float, T_hot_C: float, T_cold_C: float) -> tuple[float, float]:
    """Steady-state heating capacity P_h (eq. 6) and cooling capacity P_c (eq. 5), W, for |I|.

    P_c = α·T_c·|I| ± τ·|I|·ΔT/2 − ½·R·I² − K·ΔT ;  P_h = α·T_h·|I| ± τ·|I|·ΔT/2 + ½·R·I² − K·ΔT,
    ΔT = T_h − T_c; "±" is "+" when the pad is driven hot (I > 0) and "−" otherwise (module docstring).
    """
    i = abs(I_A)
    dT = T_hot_C - T_cold_C
    sgn = 1.0 if I_A > 0 else -1.0
    th = sgn * 0.5 * p.tau_V_K * i * dT
    Pc = p.alpha_V_K * (T_cold_C + KELVIN) * i + th - 0.5 * p.R_ohm * i * i - p.K_W_K * dT
    Ph = p.alpha_V_K * (T_hot_C + KELVIN) * i + th + 0.5 * p.R_ohm * i * i - p.K_W_K * dT
    return Ph, Pc


@dataclass(frozen=True, slots=True)
class RigParams:
    """Hardware of one rig: TEM, heat sink, grease joints, flux sensor, contact law, air loss.

    Attributes:
        tem: the module.
        side_m: side of the square pad / contact area, m.
        sink_R_K_W: heat sink to ambient resistance, K/W.
        sink_C_J_K: heat sink heat capacity, J/K.
        G_sink_plate_W_K, G_plate_sensor_W_K: grease joints, W/K.
        sensor_thickness_m: heat-flux sensor thickness, m.
        sensor_material: name in the materials table.
        sensor_cells: grid cells across the sensor (odd), or 0: graded from both faces (default).
        R_at_1N_m2K_W, force_exponent: contact law R_at_1N·F^(−n) (see
        :func:`sim.contact.contact_resistance_m2K_W`).
        detect_threshold_N: the contact detector fires above this force, N.
        h_air_W_m2K: loss of a free surface to ambient, W/(m²·K).
    """

    tem: TEMParams
    side_m: float = 0.015
    sink_R_K_W: float = 0.6
    sink_C_J_K: float = 40.0
    G_sink_plate_W_K: float = 10.0
    G_plate_sensor_W_K: float = 20.0
    sensor_thickness_m: float = 0.42e-3
    sensor_material: str = "flux_sensor"
    sensor_cells: int = 0
    R_at_1N_m2K_W: float = 5e-4
    force_exponent: float = 2.0
    detect_threshold_N: float = 0.3
    h_air_W_m2K: float = 15.0

    @property
    def area_m2(self) -> float:
        """Contact / sensor area, m²."""
        return self.side_m * self.side_m

    def with_(self, **kw) -> "RigParams":
        """A copy with some fields replaced."""
        return replace(self, **kw)


#: the tables of a TEM/rig parameter file and their keys
RIG_FILE_KEYS = {
    "datasheet": {"Imax_A", "Vmax_V", "dTmax_K", "Qmax_W", "Th_C"},
    "module": {"side_mm", "couples", "thomson_V_K", "plate_C_J_K"},
    "sink": {"R_K_W", "C_J_K", "G_sink_plate_W_K", "G_plate_sensor_W_K"},
    "sensor": {"thickness_mm", "material", "cells"},
    "contact": {"R_at_1N_m2K_W", "force_exponent", "detect_threshold_N", "h_air_W_m2K"},
}


def load_rig_params(path: str | Path | None = None) -> RigParams:
    """Read a TEM/rig parameter file (default ``sim/data/tem_15x15.toml``)."""
    path = Path(path or TEM_FILE)
    top = Section(
        path,
        "",
        load_toml(path, SceneError, "a TEM/rig parameter file"),
        set(RIG_FILE_KEYS),
        error=SceneError,
        dotted=True,
    )
    ds, mod, sink, sensor, contact = (top.table(name, keys, {}) for name, keys in RIG_FILE_KEYS.items())
    tem = TEMParams.from_datasheet(
        ds.float("Imax_A", positive=True),
        ds.float("Vmax_V", positive=True),
        ds.float("dTmax_K", positive=True),
        ds.float("Th_C"),
        tau_V_K=mod.float("thomson_V_K"),
        plate_C_J_K=mod.float("plate_C_J_K", positive=True),
    )
    cells = sensor.int("cells", 0, 0, expected="0 (graded) or an odd positive integer")
    if cells and cells % 2 == 0:
        raise sensor.fail("cells", "0 (graded) or an odd positive integer", cells)
    return RigParams(
        tem=tem,
        side_m=mod.float("side_mm", positive=True) * 1e-3,
        sink_R_K_W=sink.float("R_K_W", positive=True),
        sink_C_J_K=sink.float("C_J_K", positive=True),
        G_sink_plate_W_K=sink.float("G_sink_plate_W_K", positive=True),
        G_plate_sensor_W_K=sink.float("G_plate_sensor_W_K", positive=True),
        sensor_thickness_m=sensor.float("thickness_mm", positive=True) * 1e-3,
        sensor_material=sensor.str("material", "flux_sensor"),
        sensor_cells=cells,
        R_at_1N_m2K_W=contact.float("R_at_1N_m2K_W", positive=True),
        force_exponent=contact.float("force_exponent", positive=True),
        detect_threshold_N=contact.float("detect_threshold_N", positive=True),
        h_air_W_m2K=contact.float("h_air_W_m2K", positive=True),
    )


#: [tem] section of a scene or a --tem file: key -> (what, unit). Module values,
#: or per-couple ones times ``couples``.
TEM_KEYS = (
    "couples",
    "seebeck_V_K",
    "R_ohm",
    "K_W_K",
    "seebeck_per_couple_V_K",
    "R_per_couple_ohm",
    "K_per_couple_W_K",
    "thomson_V_K",
    "plate_C_J_K",
    "sink_plate_C_J_K",
    "pad_plate_C_J_K",
    "Imax_A",
)
_PER_COUPLE = (
    ("seebeck_V_K", "seebeck_per_couple_V_K"),
    ("R_ohm", "R_per_couple_ohm"),
    ("K_W_K", "K_per_couple_W_K"),
)


def parse_tem_section(raw: object, path: str | Path, base: RigParams | None = None) -> RigParams:
    """The rig of ``base`` (default: the shipped module) with the TEM of a ``[tem]`` table.

    Keys: ``Imax_A``; the module's Seebeck coefficient, resistance and conductance, either as module
    values (``seebeck_V_K``, ``R_ohm``, ``K_W_K``) or per couple (``seebeck_per_couple_V_K``,
    ``R_per_couple_ohm``, ``K_per_couple_W_K``, multiplied by ``couples``); the plate capacities
    (``plate_C_J_K`` for both plates; the model's two plates share one value, so ``sink_plate_C_J_K`` and
    ``pad_plate_C_J_K``, if given, must be equal); ``thomson_V_K`` (optional, default: the base module's).
    Errors are one line naming the file, the field and what was expected (:class:`SceneError`).
    """
    t = Section(str(path), "tem", raw, set(TEM_KEYS), error=SceneError, dotted=True, expected="a table [tem]")
    base = base or load_rig_params()
    couples = t.int("couples", None, 1, 10_000)
    vals = {}
    for module_key, couple_key in _PER_COUPLE:
        if t.has(module_key) == t.has(couple_key):
            raise t.fail(module_key, f"either {module_key} or {couple_key} (exactly one)")
        if t.has(module_key):
            vals[module_key] = t.float(module_key, ABSENT, 0.0, 1e3, lo_open=True)
        elif couples is None:
            raise t.fail("couples", f"the number of couples (for {couple_key})")
        else:
            vals[module_key] = couples * t.float(couple_key, ABSENT, 0.0, 10.0, lo_open=True)
    plates = {
        k: t.float(k, ABSENT, 0.0, 1e3, lo_open=True)
        for k in ("plate_C_J_K", "sink_plate_C_J_K", "pad_plate_C_J_K")
        if t.has(k)
    }
    if not plates:
        raise t.fail("plate_C_J_K", "a number in (0, 1000] (missing)")
    if max(plates.values()) - min(plates.values()) > 1e-12 * max(plates.values()):
        raise t.fail(
            "pad_plate_C_J_K",
            f"the same capacity for both plates (the lumped TEM model has one plate capacity), got {plates}",
        )
    tem = TEMParams(
        alpha_V_K=vals["seebeck_V_K"],
        R_ohm=vals["R_ohm"],
        K_W_K=vals["K_W_K"],
        tau_V_K=t.float("thomson_V_K", float(base.tem.tau_V_K), -1.0, 1.0, " V/K"),
        plate_C_J_K=next(iter(plates.values())),
        I_max_A=t.float("Imax_A", ABSENT, 0.0, 100.0, lo_open=True),
    )
    return base.with_(tem=tem)


#: what a --tem file holds (the expectation of load_tem_file's errors)
TEM_FILE_FORMATS = (
    "a TOML file with a [datasheet] table (the format of sim/data/tem_15x15.toml) "
    "or a [tem] table (the scene format)"
)


def load_tem_file(path: str | Path) -> RigParams:
    """The rig of a ``telethermo identify --tem FILE``: the file is either

    * a TEM/rig parameter file with a ``[datasheet]`` table, the format of the shipped
      ``sim/data/tem_15x15.toml`` (a lab's copy of it describing its own module): read by
      :func:`load_rig_params`, the TEM derived from the datasheet ratings; or
    * a TOML file with a ``[tem]`` table (the scene format, :func:`parse_tem_section`): the default rig
      with that module.

    SceneError names the file and the field."""
    p = Path(path)
    raw = load_toml(p, SceneError, TEM_FILE_FORMATS)
    if "tem" in raw:
        return parse_tem_section(raw["tem"], p)
    if "datasheet" in raw:
        return load_rig_params(p)
    raise SceneError.whole(p, f"no [datasheet] or [tem] table (expected {TEM_FILE_FORMATS})")


def tem_section(p: TEMParams) -> dict[str, float]:
    """The ``[tem]`` table of a module (module values): parse_tem_section's inverse."""
    return {
        "seebeck_V_K": p.alpha_V_K,
        "R_ohm": p.R_ohm,
        "K_W_K": p.K_W_K,
        "thomson_V_K": p.tau_V_K,
        "plate_C_J_K": p.plate_C_J_K,
        "Imax_A": p.I_max_A,
    }
