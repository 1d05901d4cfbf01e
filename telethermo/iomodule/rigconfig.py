"""RIG.toml: the I/O rig of one side described by a file, no code (issue 24 item 1; docs/hardware.md,
"RIG.toml reference").

Per signal of :class:`telethermo.rig.RigSample` (``T_sensor_C``, ``Q_W``, ``current_A``, ``T_sink_C``,
``contact``; ``force_N`` optional) the module, object and sub-index of its 16-bit input and its scaling::

    volts = counts * volts_per_count
    value = sign * gain * (volts - offset_V)           # °C, W, A, N (contact: touched when >= threshold)

and for the drive the output object and the inverse (amperes -> volts -> counts, clipped to ``limit_A``
and to the 16-bit range)::

    counts = round((offset_V + sign * I_A / gain) / volts_per_count)

An optional ``[tem]`` table gives the TEM's constants (Seebeck ``alpha_V_K`` V/K, resistance ``R_ohm`` Ω,
conductance ``K_W_K`` W/K, Thomson ``tau_V_K`` V/K) to the envelope's detached-sensor check
(:func:`telethermo.control.detach.tem_limits` reads them from :attr:`telethermo.iomodule.iorig.IoRig.tem`);
without it the envelope keeps its defaults (the shipped 15 × 15 mm module's).

An input reading one of its ``sentinels`` (full scale: an open thermocouple, an overload) is no value:
the signal reads NaN. ``filter_tau_ms`` > 0 low-passes a signal (first order, on the loop period).

A malformed file is refused with one line naming the file, the field and what was expected
(:class:`RigConfigError`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from telethermo.bus_config import path as bus_config_path
from telethermo.bus_config.io_eds import FILE_NAME as IO_EDS, SAMPLING_INDEX
from telethermo.inputfile import ABSENT, InputFileError, Section, load_toml, parse_toml

#: the signals a rig must give, and the optional ones
REQUIRED_SIGNALS = ("T_sensor_C", "Q_W", "current_A", "T_sink_C", "contact")
OPTIONAL_SIGNALS = ("force_N",)
#: the sim module's converter: 10 V full scale on 16 bits (telethermo.iomodule.scaling)
DEFAULT_VOLTS_PER_COUNT = 10.0 / 32768
DEFAULT_SENTINELS = (0x7FFF, -0x8000)
INT16 = (-0x8000, 0x7FFF)


class RigConfigError(InputFileError):
    """A malformed RIG.toml; the message names the file, the field and what was expected."""


@dataclass(frozen=True)
class ModuleConfig:
    """One I/O module: its node-ID and what commissioning writes into it (telethermo.iomodule.commission)."""

    name: str
    node_id: int
    eds: Path
    sampling_ms: int
    sampling_index: int | None
    consumer_ms: int
    error_behaviour: int


@dataclass(frozen=True)
class SignalConfig:
    """One input: where it is and how counts become the signal's unit."""

    name: str
    module: str
    index: int
    subindex: int
    volts_per_count: float = DEFAULT_VOLTS_PER_COUNT
    offset_V: float = 0.0
    gain: float = 1.0
    sign: int = 1
    sentinels: tuple[int, ...] = DEFAULT_SENTINELS
    filter_tau_ms: float = 0.0
    threshold: float = 0.5

    def value(self, counts: int) -> float:
        """The signal of ``counts`` in its unit (NaN for a sentinel)."""
        if counts in self.sentinels:
            return math.nan
        return self.sign * self.gain * (counts * self.volts_per_count - self.offset_V)


@dataclass(frozen=True)
class DriveConfig:
    """The TEM drive: the output object and the scaling from amperes to counts."""

    module: str
    index: int
    subindex: int
    volts_per_count: float = DEFAULT_VOLTS_PER_COUNT
    offset_V: float = 0.0
    gain: float = 1.0
    """Amplifier, A per V."""
    sign: int = 1
    limit_A: float = 3.0

    def counts(self, current_A: float) -> int:
        """The output code of ``current_A`` (clipped to ±limit_A and to 16 bits; NaN: 0 A)."""
        i = 0.0 if current_A != current_A else max(-self.limit_A, min(self.limit_A, float(current_A)))
        code = round((self.offset_V + self.sign * i / self.gain) / self.volts_per_count)
        return max(INT16[0], min(INT16[1], code))

    @property
    def zero_counts(self) -> int:
        """The code of 0 A: the module's safe substitute value (0x6444)."""
        return self.counts(0.0)


@dataclass(frozen=True)
class TemConfig:
    """The TEM's constants (guiatni eq. 1-6) for the envelope's detached-sensor check."""

    alpha_V_K: float
    """Seebeck coefficient of the whole module, V/K (0: the check off)."""
    R_ohm: float
    """Electrical resistance, Ω."""
    K_W_K: float
    """Thermal conductance between the plates, W/K."""
    tau_V_K: float = 0.0
    """Thomson coefficient, V/K (0: the term left out)."""


#: accepted ranges (inclusive) of each ``[tem]`` field: wide enough for any single- or two-stage module
TEM_RANGES = {
    "alpha_V_K": (0.0, 1.0),
    "R_ohm": (1e-3, 100.0),
    "K_W_K": (1e-4, 10.0),
    "tau_V_K": (-0.1, 0.1),
}
TEM_UNITS = {"alpha_V_K": "V/K", "R_ohm": "ohm", "K_W_K": "W/K", "tau_V_K": "V/K"}


@dataclass(frozen=True)
class RigConfig:
    """A whole RIG.toml."""

    source: str
    modules: dict[str, ModuleConfig]
    signals: dict[str, SignalConfig]
    drive: DriveConfig
    input_timeout_ms: float | None = None
    """How long a read waits for the inputs of a SYNC, ms (None: half the loop period)."""
    stale_limit: int = 3
    """Loop periods in a row without the inputs after which every signal reads NaN (the envelope trips)."""
    sdo_timeout_ms: float = 1000.0
    """How long commissioning waits for each SDO answer of a module, ms."""
    controller: str | None = None
    """The side whose controller drives this rig ("master" or "slave"; None: not said): ``rig check``'s
    default NODE, and a node program of the other side refuses the file."""
    tem: TemConfig | None = None
    """The TEM's constants (``[tem]``; None: the envelope's defaults)."""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def heartbeat_limit_ms(self) -> int:
        """The longest heartbeat period (0x1017) the controller may keep, ms: a third of the shortest time
        its modules watch it (``consumer_ms``), so that two heartbeats late or lost in a row (a loaded
        machine) do not make a module cut the drive; the node lowers its period to this at power-on."""
        return max(1, min(m.consumer_ms for m in self.modules.values()) // 3)

    def controller_heartbeat_ms(self, period_ms: int) -> int:
        """The controller's heartbeat period (0x1017), ms, once fitted to this rig: ``period_ms`` when it is
        on (> 0) and within :attr:`heartbeat_limit_ms`, else the limit (what the node writes at power-on and
        the monitor expects)."""
        return period_ms if 0 < period_ms <= self.heartbeat_limit_ms else self.heartbeat_limit_ms


def _sign(t: Section, key: str = "sign") -> int:
    v = t.get(key, 1)
    if v not in (1, -1) or isinstance(v, bool):
        raise t.fail(key, "1 or -1", v)
    return int(v)


_MODULE_KEYS = {"node_id", "eds", "sampling_ms", "sampling_index", "consumer_ms", "error_behaviour"}
_SCALE_KEYS = {"module", "object", "subindex", "volts_per_count", "offset_V", "gain", "sign"}
_SIGNAL_KEYS = _SCALE_KEYS | {"sentinels", "filter_tau_ms", "threshold"}
_DRIVE_KEYS = _SCALE_KEYS | {"limit_A"}
_TOP_KEYS = {
    "modules",
    "signals",
    "drive",
    "input_timeout_ms",
    "stale_limit",
    "sdo_timeout_ms",
    "tem",
    "controller",
}


def _module(base: Path, t: Section) -> ModuleConfig:
    eds = base / t.str("eds") if t.has("eds") else bus_config_path(IO_EDS)
    if not eds.is_file():
        raise t.fail("eds", "an EDS file (relative to the RIG.toml)", str(eds))
    sampling_index = t.int("sampling_index", SAMPLING_INDEX, -1, 0xFFFF)
    return ModuleConfig(
        name=t.path.rsplit(".", 1)[-1],
        node_id=t.int("node_id", ABSENT, 1, 127),
        eds=eds,
        sampling_ms=t.int("sampling_ms", 10, 1, 1000),
        sampling_index=None if sampling_index < 0 else sampling_index,
        consumer_ms=t.int("consumer_ms", 150, 1, 0xFFFF),
        error_behaviour=t.int("error_behaviour", 0, 0, 2),
    )


def _where(t: Section, modules: dict[str, ModuleConfig]) -> dict[str, Any]:
    return dict(
        module=t.str("module", choices=tuple(modules)),
        index=t.int("object", ABSENT, 0x1000, 0xFFFF),
        subindex=t.int("subindex", ABSENT, 0, 255),
        volts_per_count=t.float("volts_per_count", DEFAULT_VOLTS_PER_COUNT, positive=True),
        offset_V=t.float("offset_V", 0.0),
        gain=t.float("gain", 1.0, nonzero=True),
        sign=_sign(t),
    )


def _signal(t: Section, modules: dict[str, ModuleConfig]) -> SignalConfig:
    sentinels = t.list("sentinels", list(DEFAULT_SENTINELS), "a list of 16-bit codes (-32768..32767)")
    if not all(
        isinstance(s, int) and not isinstance(s, bool) and INT16[0] <= s <= INT16[1] for s in sentinels
    ):
        raise t.fail("sentinels", "a list of 16-bit codes (-32768..32767)", sentinels)
    return SignalConfig(
        name=t.path.rsplit(".", 1)[-1],
        sentinels=tuple(sentinels),
        filter_tau_ms=t.float("filter_tau_ms", 0.0, 0.0, expected="a time >= 0 ms (0: no filter)"),
        threshold=t.float("threshold", 0.5),
        **_where(t, modules),
    )


def _tem(t: Section) -> TemConfig:
    values = {
        key: t.float(key, 0.0 if key == "tau_V_K" else ABSENT, lo, hi, f" {TEM_UNITS[key]}")
        for key, (lo, hi) in TEM_RANGES.items()
    }
    return TemConfig(**values)


def parse_rig_config(text: str, source: str, base: Path | None = None) -> RigConfig:
    """A RIG.toml's text (``source`` names it in errors; ``base`` is the folder of relative paths)."""
    return _rig_config(parse_toml(text, source, RigConfigError), source, base)


def _rig_config(raw: dict[str, Any], source: str, base: Path | None) -> RigConfig:
    base = Path(".") if base is None else base
    top = Section(source, "", raw, _TOP_KEYS, error=RigConfigError, dotted=True)
    mods = top.table("modules")
    if not mods.raw:
        raise mods.fail(None, "at least one [modules.NAME] table")
    modules = {name: _module(base, mods.table(name, _MODULE_KEYS)) for name in mods.raw}
    ids = [m.node_id for m in modules.values()]
    if len(set(ids)) != len(ids):
        raise mods.fail(None, "one node_id per module", ids)
    sigs = top.table("signals", set(REQUIRED_SIGNALS + OPTIONAL_SIGNALS))
    for name in REQUIRED_SIGNALS:
        sigs.table(name)
    signals = {name: _signal(sigs.table(name, _SIGNAL_KEYS), modules) for name in sigs.raw}
    seen: dict[tuple[str, int, int], str] = {}
    for s in signals.values():
        key = (s.module, s.index, s.subindex)
        if key in seen:
            raise sigs.table(s.name).fail(
                "subindex", f"an input no other signal uses ({seen[key]} reads it)", s.subindex
            )
        seen[key] = s.name
    d = top.table("drive", _DRIVE_KEYS)
    drive = DriveConfig(limit_A=d.float("limit_A", positive=True), **_where(d, modules))
    return RigConfig(
        source=source,
        modules=modules,
        signals=signals,
        drive=drive,
        input_timeout_ms=top.float("input_timeout_ms", None, positive=True),
        stale_limit=top.int("stale_limit", 3, 1, 1000),
        sdo_timeout_ms=top.float(
            "sdo_timeout_ms", 1000.0, 10.0, 60000.0, " ms", expected="a time in [10, 60000] ms"
        ),
        tem=_tem(top.table("tem", set(TEM_RANGES))) if top.has("tem") else None,
        controller=top.str("controller", None, choices=("master", "slave")),
    )


def load_rig_config(path: str | Path) -> RigConfig:
    """Read a RIG.toml (RigConfigError for a file that cannot be read or is malformed)."""
    p = Path(path)
    return _rig_config(load_toml(p, RigConfigError, "a RIG.toml file"), str(p), p.parent)
