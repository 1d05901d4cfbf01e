"""Wiring faults of the simulated I/O module, injected on purpose (``telethermo-iomodule --fault ...``) so
that commissioning (``telethermo rig check``, :mod:`.rigcheck`) can be shown to name each of them
(docs/hardware.md, "Rig check").

Each ``--fault`` is one text, repeatable:

- ``sign:N``      input N's amplifier wired with its polarity reversed (the signal reads negated);
- ``sign:out``    the current amplifier behind the output wired reversed (+I commanded heats -> cools);
- ``scale:N:F``   input N's amplifier gain multiplied by F (e.g. ``scale:6:10``: a ×10 range jumper);
- ``open:N``      input N open circuit (reads 0x7FFF, the open-thermocouple sentinel; sets 0x2110);
- ``short:N``     input N shorted (its amplifier's input at 0 V: reads 0 counts);
- ``swap:A:B``    the wires of inputs A and B exchanged;
- ``sampling:MS`` the ADC converts every MS ms whatever 0x2100 says (a vendor module whose sampling object
  is elsewhere than the RIG.toml's ``sampling_index``: its 400 ms default stays in force);
- ``detach:S``    the sensor head comes off the pad at S s of plant time (the simulated rig's
  ``detach_sensor``: the thermocouple relaxes to the room, the flux sensor reads 0 W); not a wiring fault
  (``rig check`` cannot see it at rest): the controller's envelope trips ``sensor_detached`` in a session.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from telethermo.bus_config.io_eds import N_INPUTS
from telethermo.iomodule.scaling import InputWiring

KINDS = ("sign", "scale", "open", "short", "swap", "sampling", "detach")


class FaultError(ValueError):
    """A ``--fault`` text that is not one of the forms above; the message says what was expected."""


@dataclass(frozen=True)
class Faults:
    """The faults of one module (none by default)."""

    sign: frozenset[int] = frozenset()
    scale: dict[int, float] = field(default_factory=dict)
    opened: int = 0
    """0x2110 bits: bit n-1 = input n open."""
    short: frozenset[int] = frozenset()
    swaps: tuple[tuple[int, int], ...] = ()
    out_sign: int = 1
    sampling_ms: int | None = None
    """Forced ADC period, ms (None: 0x2100 rules)."""
    detach_at_s: float | None = None
    """Plant time at which the sensor head comes off the pad, s (None: never)."""

    def wiring(self, base: tuple[InputWiring, ...]) -> tuple[InputWiring, ...]:
        """``base`` (inputs 1..n) with the polarity, gain, short and swap faults applied."""
        wires = list(base)
        for n in sorted(self.sign):
            wires[n - 1] = replace(
                wires[n - 1], gain_V_per_unit=-wires[n - 1].gain_V_per_unit, offset_V=-wires[n - 1].offset_V
            )
        for n, factor in self.scale.items():
            wires[n - 1] = replace(wires[n - 1], gain_V_per_unit=wires[n - 1].gain_V_per_unit * factor)
        for n in self.short:
            wires[n - 1] = replace(wires[n - 1], gain_V_per_unit=0.0, offset_V=0.0)
        for a, b in self.swaps:
            wires[a - 1], wires[b - 1] = wires[b - 1], wires[a - 1]
        return tuple(wires)


def _channel(text: str, spec: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if not 1 <= n <= N_INPUTS:
        raise FaultError(f"--fault {spec}: expected an input 1..{N_INPUTS}, got {text!r}")
    return n


def parse_faults(specs: list[str]) -> Faults:
    """The faults of ``--fault`` texts (FaultError naming the text and what was expected)."""
    sign, short, scale, swaps = set(), set(), {}, []
    opened, out_sign, sampling = 0, 1, None
    detach: float | None = None
    for spec in specs:
        kind, _, rest = spec.partition(":")
        args = rest.split(":") if rest else []
        need = {"sign": 1, "open": 1, "short": 1, "sampling": 1, "scale": 2, "swap": 2, "detach": 1}.get(kind)
        if need is None or len(args) != need:
            raise FaultError(
                f"--fault {spec}: expected sign:N|sign:out, scale:N:F, open:N, short:N, "
                "swap:A:B, sampling:MS or detach:S"
            )
        if kind == "sign" and args[0] == "out":
            out_sign = -1
        elif kind == "sign":
            sign.add(_channel(args[0], spec))
        elif kind == "open":
            opened |= 1 << (_channel(args[0], spec) - 1)
        elif kind == "short":
            short.add(_channel(args[0], spec))
        elif kind == "swap":
            a, b = _channel(args[0], spec), _channel(args[1], spec)
            if a == b:
                raise FaultError(f"--fault {spec}: expected two different inputs")
            swaps.append((a, b))
        elif kind == "scale":
            n = _channel(args[0], spec)
            try:
                factor = float(args[1])
            except ValueError:
                factor = 0.0
            if not factor > 0 or factor == float("inf"):
                raise FaultError(f"--fault {spec}: expected a gain factor > 0, got {args[1]!r}")
            scale[n] = factor
        elif kind == "detach":
            try:
                detach = float(args[0])
            except ValueError:
                detach = -1.0
            if not 0.0 <= detach < float("inf"):
                raise FaultError(f"--fault {spec}: expected a plant time >= 0 s, got {args[0]!r}")
        else:
            try:
                sampling = int(args[0])
            except ValueError:
                sampling = 0
            if not 1 <= sampling <= 1000:
                raise FaultError(f"--fault {spec}: expected a sampling period 1..1000 ms, got {args[0]!r}")
    return Faults(
        sign=frozenset(sign),
        scale=scale,
        opened=opened,
        short=frozenset(short),
        swaps=tuple(swaps),
        out_sign=out_sign,
        sampling_ms=sampling,
        detach_at_s=detach,
    )
