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
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from telethermo.bus_config import path as bus_config_path
from telethermo.bus_config.io_eds import FILE_NAME as IO_EDS, SAMPLING_INDEX

#: the signals a rig must give, and the optional ones
REQUIRED_SIGNALS = ("T_sensor_C", "Q_W", "current_A", "T_sink_C", "contact")
OPTIONAL_SIGNALS = ("force_N",)
#: the sim module's converter: 10 V full scale on 16 bits (telethermo.iomodule.scaling)
DEFAULT_VOLTS_PER_COUNT = 10.0 / 32768
DEFAULT_SENTINELS = (0x7FFF, -0x8000)
INT16 = (-0x8000, 0x7FFF)


class RigConfigError(ValueError):
    """A malformed RIG.toml; the message names the file, the field and what was expected."""

    def __init__(self, source: str, fieldname: str, expected: str, got: Any = None):
        got_text = "" if got is None else f", got {got!r}"
        super().__init__(f"{source}: {fieldname}: expected {expected}{got_text}")
        self.source, self.field = source, fieldname


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
    tem: TemConfig | None = None
    """The TEM's constants (``[tem]``; None: the envelope's defaults)."""
    extra: dict[str, Any] = field(default_factory=dict)


class _Table:
    """A TOML table read field by field, each field's error naming ``source`` and its dotted path."""

    def __init__(self, source: str, prefix: str, raw: Any):
        self.source, self.prefix = source, prefix
        if not isinstance(raw, dict):
            raise RigConfigError(source, prefix, "a table", raw)
        self.raw = raw

    def name(self, key: str) -> str:
        return f"{self.prefix}.{key}" if self.prefix else key

    def check_keys(self, allowed: set[str]) -> None:
        for key in self.raw:
            if key not in allowed:
                raise RigConfigError(
                    self.source, self.name(key), f"one of {', '.join(sorted(allowed))} (an unknown key)"
                )

    def integer(self, key: str, lo: int, hi: int, default: Any = ...) -> int:
        v = self._get(key, default)
        if v is default and default is not ...:
            return v
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise RigConfigError(self.source, self.name(key), f"an integer {lo}..{hi}", v)
        return v

    def number(self, key: str, *, default: Any = ..., positive: bool = False, nonzero: bool = False) -> float:
        v = self._get(key, default)
        if v is default and default is not ...:
            return v
        ok = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
        if ok and positive and not v > 0:
            ok = False
        if ok and nonzero and v == 0:
            ok = False
        if not ok:
            what = "a number > 0" if positive else "a non-zero number" if nonzero else "a finite number"
            raise RigConfigError(self.source, self.name(key), what, v)
        return float(v)

    def text(self, key: str, choices: tuple[str, ...] | None = None) -> str:
        v = self._get(key)
        if not isinstance(v, str) or (choices is not None and v not in choices):
            raise RigConfigError(
                self.source, self.name(key), f"one of {', '.join(choices)}" if choices else "a text", v
            )
        return v

    def sign(self, key: str = "sign") -> int:
        v = self._get(key, 1)
        if v not in (1, -1) or isinstance(v, bool):
            raise RigConfigError(self.source, self.name(key), "1 or -1", v)
        return int(v)

    def _get(self, key: str, default: Any = ...) -> Any:
        if key in self.raw:
            return self.raw[key]
        if default is ...:
            raise RigConfigError(self.source, self.name(key), "a value (missing)")
        return default


_MODULE_KEYS = {"node_id", "eds", "sampling_ms", "sampling_index", "consumer_ms", "error_behaviour"}
_SCALE_KEYS = {"module", "object", "subindex", "volts_per_count", "offset_V", "gain", "sign"}
_SIGNAL_KEYS = _SCALE_KEYS | {"sentinels", "filter_tau_ms", "threshold"}
_DRIVE_KEYS = _SCALE_KEYS | {"limit_A"}
_TOP_KEYS = {"modules", "signals", "drive", "input_timeout_ms", "stale_limit", "sdo_timeout_ms", "tem"}


def _module(source: str, base: Path, name: str, raw: Any) -> ModuleConfig:
    t = _Table(source, f"modules.{name}", raw)
    t.check_keys(_MODULE_KEYS)
    eds = base / t.text("eds") if "eds" in t.raw else bus_config_path(IO_EDS)
    if not eds.is_file():
        raise RigConfigError(source, t.name("eds"), "an EDS file (relative to the RIG.toml)", str(eds))
    sampling_index = t.integer("sampling_index", -1, 0xFFFF, SAMPLING_INDEX)
    return ModuleConfig(
        name=name,
        node_id=t.integer("node_id", 1, 127),
        eds=eds,
        sampling_ms=t.integer("sampling_ms", 1, 1000, 10),
        sampling_index=None if sampling_index < 0 else sampling_index,
        consumer_ms=t.integer("consumer_ms", 1, 0xFFFF, 150),
        error_behaviour=t.integer("error_behaviour", 0, 2, 0),
    )


def _where(t: _Table, modules: dict[str, ModuleConfig]) -> dict[str, Any]:
    return dict(
        module=t.text("module", tuple(modules)),
        index=t.integer("object", 0x1000, 0xFFFF),
        subindex=t.integer("subindex", 0, 255),
        volts_per_count=t.number("volts_per_count", default=DEFAULT_VOLTS_PER_COUNT, positive=True),
        offset_V=t.number("offset_V", default=0.0),
        gain=t.number("gain", default=1.0, nonzero=True),
        sign=t.sign(),
    )


def _signal(source: str, name: str, raw: Any, modules: dict[str, ModuleConfig]) -> SignalConfig:
    t = _Table(source, f"signals.{name}", raw)
    t.check_keys(_SIGNAL_KEYS)
    sentinels = t.raw.get("sentinels", list(DEFAULT_SENTINELS))
    if not isinstance(sentinels, list) or not all(
        isinstance(s, int) and not isinstance(s, bool) and INT16[0] <= s <= INT16[1] for s in sentinels
    ):
        raise RigConfigError(source, t.name("sentinels"), "a list of 16-bit codes (-32768..32767)", sentinels)
    tau = t.number("filter_tau_ms", default=0.0)
    if tau < 0:
        raise RigConfigError(source, t.name("filter_tau_ms"), "a time >= 0 ms (0: no filter)", tau)
    return SignalConfig(
        name=name,
        sentinels=tuple(sentinels),
        filter_tau_ms=tau,
        threshold=t.number("threshold", default=0.5),
        **_where(t, modules),
    )


def _tem(source: str, raw: Any) -> TemConfig:
    t = _Table(source, "tem", raw)
    t.check_keys(set(TEM_RANGES))
    values = {}
    for key, (lo, hi) in TEM_RANGES.items():
        v = t.number(key, default=0.0) if key == "tau_V_K" else t.number(key)
        if not lo <= v <= hi:
            raise RigConfigError(source, t.name(key), f"a number {lo:g}..{hi:g} {TEM_UNITS[key]}", v)
        values[key] = v
    return TemConfig(**values)


def parse_rig_config(text: str, source: str, base: Path | None = None) -> RigConfig:
    """A RIG.toml's text (``source`` names it in errors; ``base`` is the folder of relative paths)."""
    base = Path(".") if base is None else base
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RigConfigError(source, "(syntax)", f"a TOML file ({exc})") from None
    top = _Table(source, "", raw)
    top.check_keys(_TOP_KEYS)
    mods = _Table(source, "modules", top._get("modules"))
    if not mods.raw:
        raise RigConfigError(source, "modules", "at least one [modules.NAME] table")
    modules = {name: _module(source, base, name, m) for name, m in mods.raw.items()}
    ids = [m.node_id for m in modules.values()]
    if len(set(ids)) != len(ids):
        raise RigConfigError(source, "modules", "one node_id per module", ids)
    sigs = _Table(source, "signals", top._get("signals"))
    sigs.check_keys(set(REQUIRED_SIGNALS + OPTIONAL_SIGNALS))
    for name in REQUIRED_SIGNALS:
        sigs._get(name)
    signals = {name: _signal(source, name, raw_sig, modules) for name, raw_sig in sigs.raw.items()}
    seen: dict[tuple[str, int, int], str] = {}
    for s in signals.values():
        key = (s.module, s.index, s.subindex)
        if key in seen:
            raise RigConfigError(
                source,
                f"signals.{s.name}.subindex",
                f"an input no other signal uses ({seen[key]} reads it)",
                s.subindex,
            )
        seen[key] = s.name
    d = _Table(source, "drive", top._get("drive"))
    d.check_keys(_DRIVE_KEYS)
    drive = DriveConfig(limit_A=d.number("limit_A", positive=True), **_where(d, modules))
    timeout = top.number("input_timeout_ms", default=None, positive=True)
    sdo_timeout_ms = top.number("sdo_timeout_ms", default=1000.0, positive=True)
    if not 10.0 <= sdo_timeout_ms <= 60000.0:
        raise RigConfigError(source, "sdo_timeout_ms", "a time 10..60000 ms", sdo_timeout_ms)
    return RigConfig(
        source=source,
        modules=modules,
        signals=signals,
        drive=drive,
        input_timeout_ms=timeout,
        stale_limit=top.integer("stale_limit", 1, 1000, 3),
        sdo_timeout_ms=sdo_timeout_ms,
        tem=_tem(source, raw["tem"]) if "tem" in raw else None,
    )


def load_rig_config(path: str | Path) -> RigConfig:
    """Read a RIG.toml (RigConfigError for a file that cannot be read or is malformed)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RigConfigError(
            str(p), "(file)", "a readable UTF-8 TOML file", getattr(exc, "strerror", None) or str(exc)
        ) from None
    return parse_rig_config(text, str(p), p.parent)
