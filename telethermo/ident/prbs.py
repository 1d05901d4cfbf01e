"""Pseudo-random binary sequence (PRBS) excitation with variable amplitude (guiatni §3.3).

The sign of each bit comes from a maximal-length linear feedback shift register (LFSR); each bit is held
for ``hold_samples`` sample periods (clock divider, to put the excitation's power where the thermal
dynamics are) and gets its own amplitude drawn uniformly from ``amplitude_A``. A binary sequence of
constant amplitude would make I², I³ (the polynomial terms of the NARMA model, eq. 8/9) constant or
collinear with I; the variable amplitude makes them identifiable.
"""

from __future__ import annotations

import numpy as np

# Fibonacci LFSR feedback taps (1-based bit positions) giving maximal-length sequences, 2^order - 1 bits.
_TAPS: dict[int, tuple[int, ...]] = {
    3: (3, 2),
    4: (4, 3),
    5: (5, 3),
    6: (6, 5),
    7: (7, 6),
    8: (8, 6, 5, 4),
    9: (9, 5),
    10: (10, 7),
    11: (11, 9),
    12: (12, 11, 10, 4),
    13: (13, 12, 11, 8),
    14: (14, 13, 12, 2),
    15: (15, 14),
    16: (16, 15, 13, 4),
    17: (17, 14),
    18: (18, 11),
    19: (19, 18, 17, 14),
    20: (20, 17),
}


def lfsr_bits(n_bits: int, *, order: int = 15, state: int = 1) -> np.ndarray:
    """``n_bits`` bits (0/1) of the maximal-length LFSR of ``order`` started at non-zero ``state``.

    The sequence has period 2**order - 1 and, over one period, one more 1 than 0.

    >>> bits = lfsr_bits(30, order=4)
    >>> bits[:15].tolist()
    [1, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 0, 0, 0]
    >>> int(bits[:15].sum()), bool((bits[15:] == bits[:15]).all())
    (8, True)
    """
    if order not in _TAPS:
        raise ValueError(f"LFSR order must be one of {sorted(_TAPS)}, got {order}")
    mask = (1 << order) - 1
    state &= mask
    if state == 0:
        raise ValueError("LFSR state must be non-zero (modulo 2**order)")
    taps = _TAPS[order]
    out = np.empty(n_bits, dtype=np.int8)
    for k in range(n_bits):
        bit = 0
        for t in taps:
            bit ^= (state >> (t - 1)) & 1
        out[k] = state & 1
        state = ((state << 1) | bit) & mask
    return out


def prbs(
    n_samples: int,
    *,
    amplitude_A: float | tuple[float, float] = (0.2, 1.0),
    hold_samples: int = 10,
    seed: int = 0,
    offset_A: float = 0.0,
    order: int = 15,
) -> np.ndarray:
    """A PRBS drive current with variable amplitude, A, one value per sample period.

    Args:
        n_samples: length of the sequence (samples).
        amplitude_A: bit amplitude, A: a float for a classic two-level PRBS (±amplitude), or a range
            ``(a_min, a_max)`` from which each bit's amplitude is drawn uniformly (0 <= a_min <= a_max).
        hold_samples: samples each bit is held (the PRBS clock is period_s * hold_samples).
        seed: selects the LFSR start state and the amplitudes; same seed, same sequence.
        offset_A: added to every sample, A.
        order: LFSR register length (period 2**order - 1 bits).

    Returns:
        float array of ``n_samples`` currents, A: offset ± amplitude.

    A two-level sequence, each bit held two samples, around an offset of 1 A:

    >>> prbs(6, amplitude_A=0.5, hold_samples=2, seed=1, offset_A=1.0).tolist()
    [1.5, 1.5, 1.5, 1.5, 0.5, 0.5]

    Variable amplitude: every bit's magnitude lies in the range, constant over its hold:

    >>> x = prbs(40, amplitude_A=(0.2, 1.0), hold_samples=10, seed=3)
    >>> bool(((abs(x) >= 0.2) & (abs(x) <= 1.0)).all()), len(set(x.tolist()))
    (True, 4)
    """
    if int(n_samples) != n_samples or n_samples < 0:
        raise ValueError(f"n_samples must be a non-negative integer, got {n_samples!r}")
    if int(hold_samples) != hold_samples or hold_samples < 1:
        raise ValueError(f"hold_samples must be a positive integer, got {hold_samples!r}")
    if isinstance(amplitude_A, (int, float)):
        a_min = a_max = float(amplitude_A)
    else:
        a_min, a_max = (float(a) for a in amplitude_A)
    if not (np.isfinite(a_min) and np.isfinite(a_max) and 0.0 <= a_min <= a_max):
        raise ValueError(f"amplitude_A must be >= 0 or a range 0 <= a_min <= a_max, got {amplitude_A!r}")
    n_samples, hold_samples = int(n_samples), int(hold_samples)
    rng = np.random.default_rng(seed)
    n_bits = -(-n_samples // hold_samples)
    state = int(rng.integers(1, 1 << order))
    signs = 2.0 * lfsr_bits(n_bits, order=order, state=state) - 1.0
    amps = rng.uniform(a_min, a_max, size=n_bits) if a_max > a_min else np.full(n_bits, a_min)
    return offset_A + np.repeat(signs * amps, hold_samples)[:n_samples]
