"""Counts, volts and the simulated wiring behind the I/O module's channels (docs/hardware.md).

The module's converters are 16-bit and bipolar: -32768..32767 counts is -10 V..+10 V, one count
10 V / 32768 = 305.18 µV (``volts = counts * 10 / 32768``). An input at or beyond full scale reads
:data:`OVERLOAD_POS` (0x7FFF) or :data:`OVERLOAD_NEG` (0x8000): the sentinels a real module also reports
for an open thermocouple (positive overload) or a shorted one; the output DAC clips to the same range.

The simulated rig side wires the plant's signals to the inputs through amplifiers of fixed gain
(:data:`DEFAULT_WIRING`), and the output drives the TEM through a bipolar current amplifier of
:data:`DEFAULT_AMPLIFIER_A_PER_V`. With these gains one count is 0.0030518 °C on the temperatures and
0.30518 mW on the heat flux, the least significant bits of the simulator's own measurement chain
(sim.measurement): the module is the ADC the simulated chain models.
"""

from __future__ import annotations

from dataclasses import dataclass

from telethermo.rig import RigSample

FULL_SCALE_V = 10.0
COUNTS_PER_V = 32768 / FULL_SCALE_V
OVERLOAD_POS, OVERLOAD_NEG = 0x7FFF, -0x8000
SENTINELS = (OVERLOAD_POS, OVERLOAD_NEG)


def volts_to_counts(volts: float) -> int:
    """The 16-bit converter's code of ``volts`` (V), rounded to the nearest count and clipped."""
    if volts != volts:  # NaN: an input that cannot be converted reads as an overload
        return OVERLOAD_POS
    return max(OVERLOAD_NEG, min(OVERLOAD_POS, round(volts * COUNTS_PER_V)))


def counts_to_volts(counts: int) -> float:
    """The voltage of a 16-bit code, V."""
    return counts / COUNTS_PER_V


@dataclass(frozen=True)
class InputWiring:
    """One amplifier in front of an analog input: ``volts = offset_V + gain_V_per_unit * signal``.

    ``signal`` names a field of :class:`telethermo.rig.RigSample` (``contact`` is 0/1)."""

    signal: str
    gain_V_per_unit: float
    offset_V: float = 0.0

    def volts(self, sample: RigSample) -> float:
        return self.offset_V + self.gain_V_per_unit * float(getattr(sample, self.signal))


#: 0x6401:1..6 of the simulated module: thermocouple amplifier 100 mV/°C, heat-flux amplifier 1 V/W,
#: heat-sink sensor 100 mV/°C, contact detector 0 V / 5 V, force sensor 1 V/N, current monitor 1 V/A
DEFAULT_WIRING = (
    InputWiring("T_sensor_C", 0.1),
    InputWiring("Q_W", 1.0),
    InputWiring("T_sink_C", 0.1),
    InputWiring("contact", 5.0),
    InputWiring("force_N", 1.0),
    InputWiring("current_A", 1.0),
)
#: the bipolar current amplifier behind 0x6411:1: 1 A per V (0 V = 0 A, so the substitute for 0 A is 0 counts)
DEFAULT_AMPLIFIER_A_PER_V = 1.0
