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

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from telethermo.inputfile import ABSENT, Section, load_toml
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


def _table(parent: Section, path: str, raw: Any, allowed: tuple[str, ...]) -> Section:
    """A sub-table of a scene as a Section (errors: SceneError, dotted field names)."""
    return Section(parent.file, path, raw, set(allowed), error=SceneError, dotted=True)


def _contacts(
    side: Section, duration: float, objects: dict, is_master: bool, known_materials: set[str]
) -> tuple[Touch, ...]:
    raw = side.list("contacts", [], "an array of tables [[...contacts]]")
    keys = (
        ("start_s", "end_s", "force_N", "render", "object")
        if is_master
        else ("start_s", "end_s", "force_N", "object")
    )
    out = []
    for k, raw_c in enumerate(raw):
        c = _table(side, f"{side.path}.contacts[{k}]", raw_c, keys)
        start = c.float("start_s", ABSENT, 0.0, duration)
        end = c.float("end_s", ABSENT, 0.0)
        if not end > start:
            raise c.fail("end_s", f"a time after start_s = {start}", end)
        force = c.float("force_N", ABSENT, 0.0, 100.0, lo_open=True)
        render = None
        if is_master:
            body = "finger"
            if c.raw.get("object", "finger") != "finger":
                raise c.fail(
                    "object", "'finger' (only the operator's finger touches the master)", c.raw["object"]
                )
            if c.has("render"):
                render = c.str("render")
                if render not in objects and render not in known_materials:
                    raise c.fail("render", "an object of [objects] or a material name", render)
        else:
            body = c.str("object")
            if body not in objects:
                raise c.fail(
                    "object", f"one of the scene's objects ({', '.join(sorted(objects)) or 'none'})", body
                )
        out.append(Touch(start, end, body, force, render))
    out.sort(key=lambda t: t.start_s)
    for a, b in zip(out, out[1:]):
        if b.start_s < a.end_s:
            raise side.fail(
                "contacts",
                f"non-overlapping contacts (contact at {b.start_s} s starts before the one at {a.start_s} s "
                f"ends at {a.end_s} s)",
            )
    return tuple(out)


def _finger(top: Section, known: set[str]) -> FingerParams:
    """[finger]: its layers [material, thickness_mm, perfusion_1_s], blood and core temperatures, °C."""
    fr = top.table("finger", {"layers", "T_blood_C", "core_C"}, {})
    defaults = FingerParams()
    layers = defaults.layers
    if fr.has("layers"):
        lr = fr.list("layers", expected="a non-empty array of [material, thickness_mm, perfusion_1_s]")
        if not lr:
            raise fr.fail("layers", "a non-empty array of [material, thickness_mm, perfusion_1_s]", lr)
        layers = []
        for k, L in enumerate(lr):
            if (
                not isinstance(L, list)
                or len(L) != 3
                or not isinstance(L[0], str)
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in L[1:])
            ):
                raise fr.fail(f"layers[{k}]", "[material, thickness_mm > 0, perfusion_1_s >= 0]", L)
            if L[0] not in known:
                raise fr.fail(f"layers[{k}]", f"a known material ({', '.join(sorted(known))})", L[0])
            if not (L[1] > 0 and L[2] >= 0):
                raise fr.fail(f"layers[{k}]", "thickness_mm > 0 and perfusion_1_s >= 0", L)
            layers.append((L[0], float(L[1]) * 1e-3, float(L[2])))
        layers = tuple(layers)
    return FingerParams(
        layers=layers,
        T_blood_C=fr.float("T_blood_C", defaults.T_blood_C, 30.0, 42.0),
        core_C=fr.float("core_C", defaults.core_C, 30.0, 42.0),
    )


def _objects(top: Section, known: set[str], ambient: float) -> dict[str, BodySpec]:
    """[objects.NAME]: material, thickness_mm, T0_C (°C), back."""
    objects: dict[str, BodySpec] = {}
    table = top.table("objects", None, {})
    for oname in table.raw:
        o = table.table(oname, {"material", "thickness_mm", "T0_C", "back"})
        if oname == "finger":
            raise table.fail(oname, "an object name other than 'finger' (reserved)")
        mat = o.str("material")
        if mat not in known:
            raise o.fail("material", f"a known material ({', '.join(sorted(known))})", mat)
        objects[oname] = BodySpec(
            name=oname,
            kind="slab",
            material=mat,
            thickness_m=o.float("thickness_mm", ABSENT, 0.0, 1000.0, lo_open=True) * 1e-3,
            T0_C=o.float("T0_C", ambient, -20.0, 100.0),
            back=o.str("back", "adiabatic", ("adiabatic", "ambient")),
        )
    return objects


def _start(side: Section) -> Any:
    """[master]/[slave] start: "finger" or a temperature in [15, 43] °C (None: not given)."""
    start = side.raw.get("start")
    if isinstance(start, str) and start != "finger":
        raise side.fail("start", '"finger" or a temperature in [15, 43] °C', start)
    return start if start is None or isinstance(start, str) else side.float("start", ABSENT, 15.0, 43.0)


def _sides(top: Section, kind: str, duration: float, objects: dict, known: set[str]) -> tuple:
    """[master] and [slave]: (master contacts, slave contacts, master start, slave start)."""
    for side in ("master", "slave"):  # a header with nothing under it: a file cut short, not a choice
        if top.raw.get(side) == {}:
            raise top.fail(
                side,
                f"contacts ([[{side}.contacts]]) or start under [{side}] (an empty "
                f"[{side}] table: is the file cut short?)",
            )
    mr = top.table("master", {"contacts", "start"}, {})
    master_start = _start(mr)
    master = _contacts(mr, duration, objects, True, known)
    if master_start == "finger" and not any(t.start_s <= 1e-9 < t.end_s for t in master):
        raise mr.fail(
            "start",
            '"finger" only with the finger on the display at t = 0 (a master contact from 0 s)',
            master_start,
        )
    sr = top.table("slave", {"contacts", "start"}, {})
    if sr.raw.get("start") is not None and kind != "telepresence":
        raise sr.fail("start", "no slave settings in a 'virtual' scene (master only)")
    slave_start = _start(sr)
    if kind == "virtual" and sr.raw.get("contacts"):
        raise sr.fail("contacts", "no slave contacts in a 'virtual' scene (master only)")
    slave = _contacts(sr, duration, objects, False, known)
    return master, slave, master_start, slave_start


def _noise(top: Section) -> tuple[NoiseParams, int | None]:
    """[noise]: the measurement chain's noise and its seed."""
    keys = {"seed", "T_sigma_C", "Q_sigma_W", "T_lsb_C", "Q_lsb_W", "cutoff_Hz", "enabled"}
    nz = top.table("noise", keys, {})
    d = NoiseParams()
    enabled = nz.bool("enabled", True)
    noise = NoiseParams(
        T_sigma_C=nz.float("T_sigma_C", d.T_sigma_C, 0.0, 5.0),
        Q_sigma_W=nz.float("Q_sigma_W", d.Q_sigma_W, 0.0, 5.0),
        T_lsb_C=nz.float("T_lsb_C", d.T_lsb_C, 0.0, 1.0),
        Q_lsb_W=nz.float("Q_lsb_W", d.Q_lsb_W, 0.0, 1.0),
        cutoff_Hz=nz.float("cutoff_Hz", d.cutoff_Hz, 0.0, 1e4),
        enabled=enabled,
    )
    return noise, nz.int("seed", None, 0, expected="a non-negative integer")


def _record(top: Section, period: float, duration: float) -> tuple[list[str], float]:
    """[record]: the signals to record and how often, s."""
    rec = top.table("record", {"signals", "every_s"}, {})
    signals = rec.list("signals", ["T_sensor_C", "Q_W", "current_A", "contact"], "an array of signal names")
    if not all(isinstance(s, str) for s in signals):
        raise rec.fail("signals", "an array of signal names", signals)
    for s in signals:
        if s not in RECORDABLE:
            raise rec.fail("signals", f"names among {', '.join(RECORDABLE)}", s)
    return signals, rec.float("every_s", period, period, duration)


_TOP = {"scene", "finger", "objects", "master", "slave", "noise", "record", "numerics", "tem"}


def parse_scene(raw: dict, path: str, rig_params: RigParams | None = None) -> Scene:
    """Validate a scene given as a dict (as read from TOML); ``path`` names it in errors."""
    top = Section(path, "", raw, _TOP, error=SceneError, dotted=True)
    sc = top.table("scene", {"name", "kind", "description", "duration_s", "period_s", "ambient_C"})
    name = sc.str("name", Path(path).stem)
    kind = sc.str("kind", "telepresence", KINDS)
    duration = sc.float("duration_s", ABSENT, 0.0, 1e6, lo_open=True)
    period = sc.float("period_s", 0.01, 1e-4, 1.0)
    ambient = sc.float("ambient_C", 25.0, -20.0, 60.0)
    known = set(materials())
    finger = _finger(top, known)
    objects = _objects(top, known, ambient)
    master, slave, master_start, slave_start = _sides(top, kind, duration, objects, known)
    noise, seed = _noise(top)
    signals, every = _record(top, period, duration)
    tolerance = top.table("numerics", {"tolerance_C"}, {}).float("tolerance_C", 0.05, 0.0, 10.0, lo_open=True)
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
        description=str(sc.raw.get("description", "")),
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

    Raises SceneError (a ValueError) naming the file, the field (or line) and what was expected.
    """
    p = scene_path(path_or_name)
    return parse_scene(load_toml(p, SceneError, "a scene file"), str(p))
