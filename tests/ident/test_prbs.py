"""PRBS excitation: maximal-length LFSR, seedable, variable amplitude, hold."""

import numpy as np
import pytest

from telethermo.ident.prbs import lfsr_bits, prbs


@pytest.mark.parametrize("order", [5, 7, 10])
def test_lfsr_is_maximal_length_and_balanced(order):
    period = 2**order - 1
    bits = lfsr_bits(2 * period, order=order, state=1)
    assert np.array_equal(bits[:period], bits[period:])  # periodic with 2^order - 1
    for p in range(1, period):  # and no shorter period
        if period % p == 0:
            assert not np.array_equal(bits[: period - p], bits[p:period])
    assert int(bits[:period].sum()) == 2 ** (order - 1)  # one more 1 than 0 per period


def test_prbs_is_seeded_and_holds_bits():
    a = prbs(1000, amplitude_A=(0.2, 1.0), hold_samples=10, seed=3)
    b = prbs(1000, amplitude_A=(0.2, 1.0), hold_samples=10, seed=3)
    c = prbs(1000, amplitude_A=(0.2, 1.0), hold_samples=10, seed=4)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    blocks = a.reshape(100, 10)
    assert np.all(blocks == blocks[:, :1])  # constant within each bit
    assert np.all((np.abs(a) >= 0.2) & (np.abs(a) <= 1.0))
    assert len(np.unique(np.abs(blocks[:, 0]))) > 90  # amplitudes vary bit to bit
    assert abs(np.mean(np.sign(a))) < 0.1  # about as many + as - bits


def test_prbs_two_level_and_offset():
    u = prbs(300, amplitude_A=0.5, hold_samples=3, seed=0, offset_A=0.1)
    assert set(np.round(np.unique(u), 12)) == {-0.4, 0.6}


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(hold_samples=0),
        dict(amplitude_A=(1.0, 0.5)),
        dict(amplitude_A=-1.0),
        dict(amplitude_A=float("nan")),
    ],
)
def test_prbs_rejects_bad_arguments(kwargs):
    with pytest.raises(ValueError):
        prbs(100, **kwargs)
