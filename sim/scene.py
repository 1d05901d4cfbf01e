"""Scenes: TOML files describing ambient, operator finger, objects, contact schedules, noise, timing, record.

Format (all times s, temperatures °C, forces N, lengths mm)::

    [scene]
    name = "probe_touches_al_steel_wood"
    kind = "telepresence"          # "telepresence" (master + slave) | "virtual" (master only)
    duration_s = 30.0
    period_s = 0.01
    ambient_C = 25.0

    [finger]                       # optional: the operator's finger (defaults: sim.bodies.FingerParams)
    core_C = 37.0
    T_blood_C = 37.0
    layers = [["skin", 0.6, 0.0], ["dermis", 1.5, 0.001], ["subcutaneous", 6.0, 0.0005]]  # material, mm, 1/s

    [objects.aluminium]
    material = "aluminium"
    thickness_mm = 20.0
    T0_C = 25.0                    # default: ambient
    back = "adiabatic"             # or "ambient"

    [master]                       # optional: how the display starts (default: everything at ambient, 0 A)
    start = "finger"               # "finger": the finger has rested on a display rendering air for long
                                   # (steady state, finger at its natural temperature); or a number: the
                                   # pad regulated at that temperature for long (°C)

    [slave]                        # optional: how the probe starts (default: ambient, 0 A)
    start = "finger"               # "finger": its pad held in air at the finger's natural skin temperature
                                   # (the pair has been running before t = 0); or a temperature, °C

    [[master.contacts]]            # the operator's finger on the master pad
    start_s = 0.0
    end_s = 30.0
    force_N = 8.0
    render = "brass"               # virtual scenes: the material the display should render (optional)

    [[slave.contacts]]             # the slave probe touching objects
    start_s = 2.0
    end_s = 5.5
    object = "aluminium"
    force_N = 8.0

    [noise]                        # optional; see sim.measurement.NoiseParams
    seed = 1
    T_sigma_C = 0.02
    Q_sigma_W = 0.002
    cutoff_Hz = 5.0

    [tem]                          # optional: the rigs' thermo-electric module
                                   #   (default: sim/data/tem_15x15.toml)
    couples = 31                   # needed only with per-couple values (seebeck_per_couple_V_K,
    seebeck_V_K = 0.0125           #   R_per_couple_ohm, K_per_couple_W_K); else module values: Seebeck
    R_ohm = 0.971                  #   V/K, resistance ohm, conductance W/K (see sim.tem.parse_tem_section)
    K_W_K = 0.0652
    thomson_V_K = 1.9e-3           # optional
    plate_C_J_K = 0.62             # each plate's heat capacity, J/K
    Imax_A = 3.0

    [numerics]                     # optional: error tolerance that picks the grid
                                   #   (sim.GridSettings.for_tolerance)
    tolerance_C = 0.05

    [record]                       # optional: what a runner should record
    signals = ["T_sensor_C", "Q_W", "current_A"]
    every_s = 0.01
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from telethermo.sim.bodies import FingerParams
from telethermo.sim.errors import SceneError
from telethermo.sim.materials import materials
from telethermo.sim.measurement import NoiseParams
from telethermo.sim.tem import RigParams, load_rig_params, parse_tem_section
from telethermo.sim.touch import BodySpec, Touch

SCENES_DIR = Path(__file__).resolve().parent / "scenes"
KINDS = ("telepresence", "virtual")
RECORDABLE = (
    "T_sensor_C",
    "Q_W",
    "current_A",
    "contact",
    "T_sink_C",
    "force_N",
    "T_pad_C",
    "T_surface_C",
    "T_sensor_true_C",
    "Q_true_W",
    "T_contact_C",
    "Q_finger_W",
)


@dataclass(frozen=True)
class Scene:
    """A parsed, validated scene."""

    name: str
    path: str
    kind: str
    duration_s: float
    period_s: float
    ambient_C: float
    finger: FingerParams
    objects: dict[str, BodySpec]
    master_contacts: tuple[Touch, ...]
    slave_contacts: tuple[Touch, ...]
    noise: NoiseParams
    seed: int | None
    record_signals: tuple[str, ...]
    record_every_s: float
    rig_params: RigParams
    description: str = ""
    tolerance_C: float = 0.05
    master_start: str | float | None = None
    slave_start: str | float | None = None

    @property
    def rigs(self) -> tuple[str, ...]:
        return ("master", "slave") if self.kind == "telepresence" else ("master",)


def shipped_scenes() -> list[str]:
    """Names of the scenes shipped in sim/scenes/."""
    return sorted(p.stem for p in SCENES_DIR.glob("*.toml"))


def _is_finite(v: int | float) -> bool:
    """True for a number a float can hold (TOML integers have no size limit)."""
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


class _R:
    """Typed field reader that raises SceneError naming the file and field."""

    def __init__(self, path: str) -> None:
        self.path = path

    def known(self, raw: dict, allowed: tuple[str, ...], prefix: str) -> None:
        """Refuse unknown keys (a typo must not be silently ignored)."""
        for key in raw:
            if key not in allowed:
                raise SceneError(self.path, prefix + key, f"a known field ({', '.join(allowed)})")

    def table(self, raw: dict, key: str, prefix: str = "", required: bool = False) -> dict:
        v = raw.get(key)
        if v is None:
            if required:
                raise SceneError(self.path, prefix + key, "a table")
            return {}
        if not isinstance(v, dict):
            raise SceneError(self.path, prefix + key, "a table", v)
        return v

    def num(
        self,
        raw: dict,
        key: str,
        prefix: str,
        default: Any = None,
        lo: float = -math.inf,
        hi: float = math.inf,
        lo_open: bool = False,
    ) -> float:
        v = raw.get(key, default)
        field_ = prefix + key
        if v is None:
            raise SceneError(self.path, field_, "a number (required)")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not _is_finite(v):
            raise SceneError(self.path, field_, "a finite number", v)
        if (v <= lo if lo_open else v < lo) or v > hi:
            rng = f"{'(' if lo_open else '['}{lo}, {hi}]"
            raise SceneError(self.path, field_, f"a number in {rng}", v)
        return float(v)

    def string(
        self, raw: dict, key: str, prefix: str, default: Any = None, choices: tuple | None = None
    ) -> str:
        v = raw.get(key, default)
        if not isinstance(v, str) or not v:
            raise SceneError(
                self.path,
                prefix + key,
                "a non-empty string" + (f" (one of {', '.join(choices)})" if choices else ""),
                v,
            )
        if choices and v not in choices:
            raise SceneError(self.path, prefix + key, f"one of {', '.join(choices)}", v)
        return v


def _contacts(
    r: _R,
    raw: list,
    prefix: str,
    duration: float,
    objects: dict,
    kind: str,
    is_master: bool,
    known_materials: set[str],
) -> tuple[Touch, ...]:
    if not isinstance(raw, list):
        raise SceneError(r.path, prefix, "an array of tables [[...contacts]]", raw)
    out = []
    for k, c in enumerate(raw):
        p = f"{prefix}[{k}]."
        if not isinstance(c, dict):
            raise SceneError(r.path, prefix + f"[{k}]", "a table", c)
        r.known(
            c,
            ("start_s", "end_s", "force_N", "render", "object")
            if is_master
            else ("start_s", "end_s", "force_N", "object"),
            p,
        )
        start = r.num(c, "start_s", p, lo=0.0, hi=duration)
        end = r.num(c, "end_s", p, lo=0.0, hi=math.inf)
        if not end > start:
            raise SceneError(r.path, p + "end_s", f"a time after start_s = {start}", end)
        force = r.num(c, "force_N", p, lo=0.0, hi=100.0, lo_open=True)
        render = None
        if is_master:
            body = "finger"
            if "object" in c and c["object"] != "finger":
                raise SceneError(
                    r.path,
                    p + "object",
                    "'finger' (only the operator's finger touches the master)",
                    c["object"],
                )
            if "render" in c:
                render = r.string(c, "render", p)
                if render not in objects and render not in known_materials:
                    raise SceneError(
                        r.path, p + "render", "an object of [objects] or a material name", render
                    )
        else:
            body = r.string(c, "object", p)
            if body not in objects:
                raise SceneError(
                    r.path,
                    p + "object",
                    f"one of the scene's objects ({', '.join(sorted(objects)) or 'none'})",
                    body,
                )
        out.append(Touch(start, end, body, force, render))
    out.sort(key=lambda t: t.start_s)
    for k, (a, b) in enumerate(zip(out, out[1:])):
        if b.start_s < a.end_s:
            raise SceneError(
                r.path,
                prefix,
                f"non-overlapping contacts (contact at {b.start_s} s starts before the one at {a.start_s} s "
                f"ends at {a.end_s} s)",
            )
    return tuple(out)


def _finger(r: _R, raw: dict, path: str, known: set[str]) -> FingerParams:
    """[finger]: its layers [material, thickness_mm, perfusion_1_s], blood and core temperatures, °C."""
    fr = r.table(raw, "finger")
    r.known(fr, ("layers", "T_blood_C", "core_C"), "finger.")
    defaults = FingerParams()
    layers = defaults.layers
    if "layers" in fr:
        lr = fr["layers"]
        if not isinstance(lr, list) or not lr:
            raise SceneError(
                path, "finger.layers", "a non-empty array of [material, thickness_mm, perfusion_1_s]", lr
            )
        layers = []
        for k, L in enumerate(lr):
            if (
                not isinstance(L, list)
                or len(L) != 3
                or not isinstance(L[0], str)
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in L[1:])
            ):
                raise SceneError(
                    path, f"finger.layers[{k}]", "[material, thickness_mm > 0, perfusion_1_s >= 0]", L
                )
            if L[0] not in known:
                raise SceneError(
                    path, f"finger.layers[{k}]", f"a known material ({', '.join(sorted(known))})", L[0]
                )
            if not (L[1] > 0 and L[2] >= 0):
                raise SceneError(path, f"finger.layers[{k}]", "thickness_mm > 0 and perfusion_1_s >= 0", L)
            layers.append((L[0], float(L[1]) * 1e-3, float(L[2])))
        layers = tuple(layers)
    return FingerParams(
        layers=layers,
        T_blood_C=r.num(fr, "T_blood_C", "finger.", default=defaults.T_blood_C, lo=30.0, hi=42.0),
        core_C=r.num(fr, "core_C", "finger.", default=defaults.core_C, lo=30.0, hi=42.0),
    )


def _objects(r: _R, raw: dict, path: str, known: set[str], ambient: float) -> dict[str, BodySpec]:
    """[objects.NAME]: material, thickness_mm, T0_C (°C), back."""
    objects: dict[str, BodySpec] = {}
    for oname, o in r.table(raw, "objects").items():
        p = f"objects.{oname}."
        if not isinstance(o, dict):
            raise SceneError(path, f"objects.{oname}", "a table", o)
        r.known(o, ("material", "thickness_mm", "T0_C", "back"), p)
        if oname == "finger":
            raise SceneError(path, f"objects.{oname}", "an object name other than 'finger' (reserved)")
        mat = r.string(o, "material", p)
        if mat not in known:
            raise SceneError(path, p + "material", f"a known material ({', '.join(sorted(known))})", mat)
        objects[oname] = BodySpec(
            name=oname,
            kind="slab",
            material=mat,
            thickness_m=r.num(o, "thickness_mm", p, lo=0.0, hi=1000.0, lo_open=True) * 1e-3,
            T0_C=r.num(o, "T0_C", p, default=ambient, lo=-20.0, hi=100.0),
            back=r.string(o, "back", p, default="adiabatic", choices=("adiabatic", "ambient")),
        )
    return objects


def _start(r: _R, table: dict, path: str, side: str) -> Any:
    """[master]/[slave] start: "finger" or a temperature in [15, 43] °C (None: not given)."""
    start = table.get("start")
    if start is None:
        return None
    if isinstance(start, str):
        if start != "finger":
            raise SceneError(path, f"{side}.start", '"finger" or a temperature in [15, 43] °C', start)
        return start
    return r.num(table, "start", f"{side}.", lo=15.0, hi=43.0)


def _sides(r: _R, raw: dict, path: str, kind: str, duration: float, objects: dict, known: set[str]) -> tuple:
    """[master] and [slave]: (master contacts, slave contacts, master start, slave start)."""
    for side in ("master", "slave"):  # a header with nothing under it: a file cut short, not a choice
        if side in raw and raw[side] == {}:
            raise SceneError(
                path,
                side,
                f"contacts ([[{side}.contacts]]) or start under [{side}] (an empty "
                f"[{side}] table: is the file cut short?)",
            )
    mr = r.table(raw, "master")
    r.known(mr, ("contacts", "start"), "master.")
    master_start = _start(r, mr, path, "master")
    master = _contacts(r, mr.get("contacts", []), "master.contacts", duration, objects, kind, True, known)
    if master_start == "finger" and not any(t.start_s <= 1e-9 < t.end_s for t in master):
        raise SceneError(
            path,
            "master.start",
            '"finger" only with the finger on the display at t = 0 (a master contact from 0 s)',
            master_start,
        )
    sr = r.table(raw, "slave")
    r.known(sr, ("contacts", "start"), "slave.")
    if sr.get("start") is not None and kind != "telepresence":
        raise SceneError(path, "slave.start", "no slave settings in a 'virtual' scene (master only)")
    slave_start = _start(r, sr, path, "slave")
    if kind == "virtual" and sr.get("contacts"):
        raise SceneError(path, "slave.contacts", "no slave contacts in a 'virtual' scene (master only)")
    slave = _contacts(r, sr.get("contacts", []), "slave.contacts", duration, objects, kind, False, known)
    return master, slave, master_start, slave_start


def _noise(r: _R, raw: dict, path: str) -> tuple[NoiseParams, int | None]:
    """[noise]: the measurement chain's noise and its seed."""
    nz = r.table(raw, "noise")
    r.known(nz, ("seed", "T_sigma_C", "Q_sigma_W", "T_lsb_C", "Q_lsb_W", "cutoff_Hz", "enabled"), "noise.")
    if not isinstance(nz.get("enabled", True), bool):
        raise SceneError(path, "noise.enabled", "true or false", nz.get("enabled"))
    d = NoiseParams()
    noise = NoiseParams(
        T_sigma_C=r.num(nz, "T_sigma_C", "noise.", default=d.T_sigma_C, lo=0.0, hi=5.0),
        Q_sigma_W=r.num(nz, "Q_sigma_W", "noise.", default=d.Q_sigma_W, lo=0.0, hi=5.0),
        T_lsb_C=r.num(nz, "T_lsb_C", "noise.", default=d.T_lsb_C, lo=0.0, hi=1.0),
        Q_lsb_W=r.num(nz, "Q_lsb_W", "noise.", default=d.Q_lsb_W, lo=0.0, hi=1.0),
        cutoff_Hz=r.num(nz, "cutoff_Hz", "noise.", default=d.cutoff_Hz, lo=0.0, hi=1e4),
        enabled=bool(nz.get("enabled", True)),
    )
    seed = nz.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise SceneError(path, "noise.seed", "a non-negative integer", seed)
    return noise, seed


def _record(r: _R, raw: dict, path: str, period: float, duration: float) -> tuple[list[str], float]:
    """[record]: the signals to record and how often, s."""
    rec = r.table(raw, "record")
    r.known(rec, ("signals", "every_s"), "record.")
    signals = rec.get("signals", ["T_sensor_C", "Q_W", "current_A", "contact"])
    if not isinstance(signals, list) or not all(isinstance(s, str) for s in signals):
        raise SceneError(path, "record.signals", "an array of signal names", signals)
    for s in signals:
        if s not in RECORDABLE:
            raise SceneError(path, "record.signals", f"names among {', '.join(RECORDABLE)}", s)
    return signals, r.num(rec, "every_s", "record.", default=period, lo=period, hi=duration)


def parse_scene(raw: dict, path: str, rig_params: RigParams | None = None) -> Scene:
    """Validate a scene given as a dict (as read from TOML); ``path`` names it in errors."""
    r = _R(path)
    r.known(raw, ("scene", "finger", "objects", "master", "slave", "noise", "record", "numerics", "tem"), "")
    sc = r.table(raw, "scene", required=True)
    r.known(sc, ("name", "kind", "description", "duration_s", "period_s", "ambient_C"), "scene.")
    name = r.string(sc, "name", "scene.", default=Path(path).stem)
    kind = r.string(sc, "kind", "scene.", default="telepresence", choices=KINDS)
    duration = r.num(sc, "duration_s", "scene.", lo=0.0, hi=1e6, lo_open=True)
    period = r.num(sc, "period_s", "scene.", default=0.01, lo=1e-4, hi=1.0)
    ambient = r.num(sc, "ambient_C", "scene.", default=25.0, lo=-20.0, hi=60.0)
    known = set(materials())
    finger = _finger(r, raw, path, known)
    objects = _objects(r, raw, path, known, ambient)
    master, slave, master_start, slave_start = _sides(r, raw, path, kind, duration, objects, known)
    noise, seed = _noise(r, raw, path)
    signals, every = _record(r, raw, path, period, duration)
    num = r.table(raw, "numerics")
    r.known(num, ("tolerance_C",), "numerics.")
    tolerance = r.num(num, "tolerance_C", "numerics.", default=0.05, lo=0.0, hi=10.0, lo_open=True)
    rig = rig_params or load_rig_params()
    if "tem" in raw:
        rig = parse_tem_section(raw["tem"], path, rig)

    return Scene(
        name=name,
        path=str(path),
        kind=kind,
        duration_s=duration,
        period_s=period,
        ambient_C=ambient,
        finger=finger,
        objects=objects,
        master_contacts=master,
        slave_contacts=slave,
        noise=noise,
        seed=seed,
        record_signals=tuple(signals),
        record_every_s=every,
        rig_params=rig,
        description=str(sc.get("description", "")),
        tolerance_C=tolerance,
        master_start=master_start,
        slave_start=slave_start,
    )


def scene_path(path_or_name: str | Path) -> Path:
    """The file of a scene given as a path, or as the name of a shipped scene (no suffix, no such file)."""
    p = Path(path_or_name)
    if not p.suffix and not p.exists():
        cand = SCENES_DIR / f"{p.name}.toml"
        if not cand.exists():
            raise SceneError(
                str(path_or_name),
                "<name>",
                f"a scene file or a shipped scene ({', '.join(shipped_scenes())})",
            )
        p = cand
    return p


def load_scene(path_or_name: str | Path) -> Scene:
    """Load a scene from a TOML path, or a shipped scene by name (e.g. "probe_touches_al_steel_wood").

    Raises SceneError (a ValueError) naming the file, the field and what was expected.
    """
    p = scene_path(path_or_name)
    try:
        with open(p, "rb") as fh:
            raw = tomllib.load(fh)
    except FileNotFoundError:
        raise SceneError(str(p), "<file>", "an existing scene file") from None
    except IsADirectoryError:
        raise SceneError(str(p), "<file>", "a file, not a directory") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(str(p), "<toml>", f"valid TOML ({exc})") from None
    except UnicodeDecodeError as exc:
        raise SceneError(str(p), "<file>", f"UTF-8 text ({exc})") from None
    return parse_scene(raw, str(p))
