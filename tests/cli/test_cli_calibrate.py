"""calibrate-finger: eq. 1 inverted from touches, the live touch detector, and --apply by SDO."""

from __future__ import annotations

import pytest

from telethermo.cli.calibrate import measure_touch
from telethermo.remote.errors import Failure
from telethermo.cli.main import EXIT_OK, EXIT_USAGE


def contact_T(Tf0, Tp0, beta):
    """yamamoto eq. 1 with relative effusivities: the contact temperature of finger and pad."""
    return (Tf0 + beta * Tp0) / (1 + beta)


def test_two_touches_recover_beta_pad_and_finger_temperature_and_apply(nodes, cli):
    beta, Tf0 = 2.23, 33.4  # yamamoto Table 1: the pad's β
    t1, t2 = contact_T(Tf0, 28.0, beta), contact_T(Tf0, 36.0, beta)
    code, out, err = cli(
        "calibrate-finger", *nodes.bus, "--touch", f"28:{t1}", "--touch", f"36:{t2}", "--apply"
    )
    assert code == EXIT_OK, err
    m = nodes.devices["master"]
    assert m.read("pad_beta") == pytest.approx(beta, rel=1e-5)
    assert m.read("finger_T0_C") == pytest.approx(Tf0, abs=1e-4)
    assert "beta_pad = 2.2300" in out and "T_finger0 = 33.400" in out


def test_one_touch_needs_the_finger_temperature(cli):
    code, _, err = cli("calibrate-finger", "--touch", "28:30.9")
    # the option's name, not the Python argument's (issue 25: it said "give T_finger0_C")
    assert code == EXIT_USAGE and err == (
        "telethermo calibrate-finger: error: need >= 2 touches with pre-sets "
        ">= 0.5 °C apart (or give --finger-temp)\n"
    )
    code, out, _ = cli(
        "calibrate-finger", "--touch", f"28:{contact_T(33.0, 28.0, 1.5)}", "--finger-temp", "33"
    )
    assert code == EXIT_OK and "beta_pad = 1.5000" in out
    code, _, err = cli("calibrate-finger", "--touch", "28-30")
    assert code == EXIT_USAGE and "expected T_PAD0:T_CONTACT" in err


class FakeClockPad:
    """A pad sampled every 20 ms on an injected clock: at 28 °C untouched; touched at t = 1.0 s,
    the sensor then reads the contact temperature 30.9 °C (plus a first 0.05 s transient)."""

    def __init__(self, touch_at=1.0, release_at=9.0):
        self.t, self.touch_at, self.release_at = 0.0, touch_at, release_at

    def clock(self):
        return self.t

    def sleep(self, dt):
        self.t += dt

    def read(self):
        touched = self.touch_at <= self.t < self.release_at
        if not touched:
            return 28.0, False
        return (29.5 if self.t < self.touch_at + 0.05 else 30.9), True


def test_live_touch_windows_pre_contact_and_early_time():
    pad = FakeClockPad()
    p0, c = measure_touch(pad.read, timeout_s=5, poll_s=0.02, clock=pad.clock, sleep=pad.sleep)
    assert p0 == pytest.approx(28.0) and c == pytest.approx(30.9)  # the transient is outside 0.1..1 s
    short = FakeClockPad(release_at=1.5)
    with pytest.raises(Failure, match="left the pad within 1 s"):
        measure_touch(short.read, timeout_s=5, poll_s=0.02, clock=short.clock, sleep=short.sleep)
    never = FakeClockPad(touch_at=99)
    with pytest.raises(Failure, match="no touch within 5 s"):
        measure_touch(never.read, timeout_s=5, poll_s=0.02, clock=never.clock, sleep=never.sleep)
