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

import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

from telethermo.sim.errors import SceneError

KELVIN = 273.15
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


def _num(raw: dict, path: Path, section: str, key: str, positive: bool = True) -> float:
    v = raw.get(section, {}).get(key)
    if (
        not isinstance(v, (int, float))
        or isinstance(v, bool)
        or not math.isfinite(v)
        or (positive and v <= 0)
    ):
        raise SceneError(path, f"{section}.{key}", "a positive number" if positive else "a number", v)
    return float(v)


def load_rig_params(path: str | Path | None = None) -> RigParams:
    """Read a TEM/rig parameter file (default ``sim/data/tem_15x15.toml``)."""
    path = Path(path or TEM_FILE)
    with open(path, "rb") as fh:
        try:
            raw = tomllib.load(fh)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(path, "<toml>", f"valid TOML ({exc})") from None
    tem = TEMParams.from_datasheet(
        _num(raw, path, "datasheet", "Imax_A"),
        _num(raw, path, "datasheet", "Vmax_V"),
        _num(raw, path, "datasheet", "dTmax_K"),
        _num(raw, path, "datasheet", "Th_C", positive=False),
        tau_V_K=_num(raw, path, "module", "thomson_V_K", positive=False),
        plate_C_J_K=_num(raw, path, "module", "plate_C_J_K"),
    )
    cells = raw.get("sensor", {}).get("cells", 0)
    if not isinstance(cells, int) or isinstance(cells, bool) or cells < 0 or (cells and cells % 2 == 0):
        raise SceneError(path, "sensor.cells", "0 (graded) or an odd positive integer", cells)
    return RigParams(
        tem=tem,
        side_m=_num(raw, path, "module", "side_mm") * 1e-3,
        sink_R_K_W=_num(raw, path, "sink", "R_K_W"),
        sink_C_J_K=_num(raw, path, "sink", "C_J_K"),
        G_sink_plate_W_K=_num(raw, path, "sink", "G_sink_plate_W_K"),
        G_plate_sensor_W_K=_num(raw, path, "sink", "G_plate_sensor_W_K"),
        sensor_thickness_m=_num(raw, path, "sensor", "thickness_mm") * 1e-3,
        sensor_material=str(raw.get("sensor", {}).get("material", "flux_sensor")),
        sensor_cells=cells,
        R_at_1N_m2K_W=_num(raw, path, "contact", "R_at_1N_m2K_W"),
        force_exponent=_num(raw, path, "contact", "force_exponent"),
        detect_threshold_N=_num(raw, path, "contact", "detect_threshold_N"),
        h_air_W_m2K=_num(raw, path, "contact", "h_air_W_m2K"),
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


def _tem_num(raw: dict, path: str, key: str, lo: float, hi: float, default: float | None = None) -> float:
    v = raw.get(key, default)
    if v is None:
        raise SceneError(path, f"tem.{key}", f"a number in ({lo}, {hi}] (required)")
    if (
        isinstance(v, bool)
        or not isinstance(v, (int, float))
        or not math.isfinite(float(v))
        or not lo < v <= hi
    ):
        raise SceneError(path, f"tem.{key}", f"a number in ({lo}, {hi}]", v)
    return float(v)


def parse_tem_section(raw: object, path: str | Path, base: RigParams | None = None) -> RigParams:
    """The rig of ``base`` (default: the shipped module) with the TEM of a ``[tem]`` table.

    Keys: ``Imax_A``; the module's Seebeck coefficient, resistance and conductance, either as module
    values (``seebeck_V_K``, ``R_ohm``, ``K_W_K``) or per couple (``seebeck_per_couple_V_K``,
    ``R_per_couple_ohm``, ``K_per_couple_W_K``, multiplied by ``couples``); the plate capacities
    (``plate_C_J_K`` for both plates; the model's two plates share one value, so ``sink_plate_C_J_K`` and
    ``pad_plate_C_J_K``, if given, must be equal); ``thomson_V_K`` (optional, default: the base module's).
    Errors are one line naming the file, the field and what was expected (:class:`SceneError`).
    """
    path = str(path)
    if not isinstance(raw, dict):
        raise SceneError(path, "tem", "a table [tem]", raw)
    for key in raw:
        if key not in TEM_KEYS:
            raise SceneError(path, f"tem.{key}", f"a known field ({', '.join(TEM_KEYS)})")
    base = base or load_rig_params()
    couples = raw.get("couples")
    if couples is not None and (
        isinstance(couples, bool) or not isinstance(couples, int) or not 0 < couples <= 10_000
    ):
        raise SceneError(path, "tem.couples", "an integer in [1, 10000]", couples)
    vals = {}
    for module_key, couple_key in _PER_COUPLE:
        if (module_key in raw) == (couple_key in raw):
            raise SceneError(path, f"tem.{module_key}", f"either {module_key} or {couple_key} (exactly one)")
        if module_key in raw:
            vals[module_key] = _tem_num(raw, path, module_key, 0.0, 1e3)
        elif couples is None:
            raise SceneError(path, "tem.couples", f"the number of couples (for {couple_key})")
        else:
            vals[module_key] = couples * _tem_num(raw, path, couple_key, 0.0, 10.0)
    plates = {
        k: _tem_num(raw, path, k, 0.0, 1e3)
        for k in ("plate_C_J_K", "sink_plate_C_J_K", "pad_plate_C_J_K")
        if k in raw
    }
    if not plates:
        raise SceneError(path, "tem.plate_C_J_K", "a number in (0.0, 1000.0] (required)")
    if max(plates.values()) - min(plates.values()) > 1e-12 * max(plates.values()):
        raise SceneError(
            path,
            "tem.pad_plate_C_J_K",
            f"the same capacity for both plates (the lumped TEM model has one plate capacity), got {plates}",
        )
    th = raw.get("thomson_V_K", base.tem.tau_V_K)
    if (
        isinstance(th, bool)
        or not isinstance(th, (int, float))
        or not math.isfinite(float(th))
        or abs(th) > 1.0
    ):
        raise SceneError(path, "tem.thomson_V_K", "a number in [-1, 1] V/K", th)
    tem = TEMParams(
        alpha_V_K=vals["seebeck_V_K"],
        R_ohm=vals["R_ohm"],
        K_W_K=vals["K_W_K"],
        tau_V_K=float(th),
        plate_C_J_K=next(iter(plates.values())),
        I_max_A=_tem_num(raw, path, "Imax_A", 0.0, 100.0),
    )
    return base.with_(tem=tem)


def load_tem_file(path: str | Path) -> RigParams:
    """The default rig with the TEM of a TOML file's ``[tem]`` table (the scene format; ``telethermo identify
    --tem FILE``). SceneError names the file and the field."""
    p = Path(path)
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except (FileNotFoundError, IsADirectoryError):
        raise SceneError(str(p), "<file>", "an existing TOML file with a [tem] table") from None
    except UnicodeDecodeError as exc:
        raise SceneError(str(p), "<file>", f"UTF-8 text ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(str(p), "<toml>", f"valid TOML ({exc})") from None
    if "tem" not in raw:
        raise SceneError(str(p), "tem", "a [tem] table")
    return parse_tem_section(raw["tem"], p)


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
