"""Hardware-rig factories for the node programs' tests (``--rig MODULE:FACTORY``): drivers that go wrong, and
a
pad whose contact flag the test sets (tests/cli/test_cli_identify_contact.py)."""

from __future__ import annotations

import dataclasses
import os

from telethermo.sim.wallclock import pads_in_air_master


def wrong_period():
    """A working rig at 20 ms on a 10 ms bus."""
    rig = pads_in_air_master()
    rig.period_s = 0.02
    return rig


def no_device():
    """A driver whose device is not there."""
    raise OSError("no thermal display on /dev/ttyUSB9")


def not_a_rig():
    """A factory returning something else."""
    return object()


def configured(port: str, period_s: float = 0.01, gain: float = 1.0):
    """A driver that takes its settings as keyword arguments (``--rig-config FILE.toml``): a working rig
    (the wall-clock pads in air) that only opens when given the port it expects."""
    if port != "/dev/ttyTT0":
        raise OSError(f"no thermal display on {port}")
    rig = pads_in_air_master()
    rig.period_s = period_s
    rig.gain = gain
    return rig


def touched_while_file(flag: str):
    """The wall-clock master pad in air whose contact detector (the rig's flag) says touched while the file
    ``flag`` exists: a bench probe put on something and lifted, on the operator's (the test's) cue."""
    rig = pads_in_air_master()
    read = rig.read

    def read_with_flag():
        s = read()
        return dataclasses.replace(s, contact=True, force_N=2.0) if os.path.exists(flag) else s

    rig.read = read_with_flag
    return rig
