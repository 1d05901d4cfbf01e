"""Contact detection from the heat-flux signal."""

import math

import numpy as np

from telethermo.control.contact import ContactParams, ContactSource, ContactState, contact_step


def _flux_of_touch(t, t_on, t_off, dT=1.5, b=1100.0, S=2.25e-4, tau=0.02):
    """Flux of a finger touching a pad dT warmer (semi-infinite finger), seen through a 1st-order filter."""
    q = np.where((t >= t_on) & (t < t_off), b * dT * S / np.sqrt(np.pi * np.maximum(t - t_on, 0.005)), 0.0)
    out = np.empty_like(q)
    y = 0.0
    for k, x in enumerate(q):
        y += (x - y) * min(1.0, 0.01 / tau)
        out[k] = y
    return out


def test_detects_touch_within_two_samples_and_release():
    t = np.arange(0, 6, 0.01)
    rng = np.random.default_rng(0)
    Q = _flux_of_touch(t, 2.0, 4.0) + 0.02 + rng.normal(0, 0.005, t.size)
    p, s = ContactParams(), ContactState()
    dec = []
    for q in Q:
        s = contact_step(p, s, float(q), False, 0.01)
        dec.append(s.contact)
    dec = np.array(dec)
    on = t[np.argmax(dec)]
    assert 2.0 <= on <= 2.02
    assert not dec[t < 2.0].any()
    off = t[np.where(dec)[0][-1]]
    assert 4.0 <= off <= 4.5
    assert not dec[t > 4.6].any()


def test_flag_sources():
    p = ContactParams(source=ContactSource.FLAG)
    s = contact_step(p, ContactState(), 5.0, False, 0.01)
    assert not s.contact
    s = contact_step(p, s, 0.0, True, 0.01)
    assert s.contact
    p2 = ContactParams(source=ContactSource.FLUX_OR_FLAG)
    assert contact_step(p2, ContactState(), 0.0, True, 0.01).contact


def test_nan_flux_keeps_decision():
    s = ContactState(contact=True)
    assert contact_step(ContactParams(), s, math.nan, False, 0.01).contact
