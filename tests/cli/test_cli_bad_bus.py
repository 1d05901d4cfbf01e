"""A SocketCAN bus that cannot be opened is one line that says why (issue 13: without kernel CAN the CLI
said only ``[Errno 97]``). On this host the kernel has no AF_CAN; inside vcan-run it has, and the interface
does not exist: either way the line names the cause and what to do."""

from __future__ import annotations

import errno

from telethermo.cli.main import EXIT_FAIL, main
from telethermo.transport.bus import socketcan_hint


def test_the_hints_name_the_cause():
    assert "no SocketCAN" in socketcan_hint(OSError(errno.EAFNOSUPPORT, "x"), "can0")
    assert "no CAN interface 'can9'" in socketcan_hint(OSError(errno.ENODEV, "x"), "can9")
    assert "ip link set can0 up" in socketcan_hint(OSError(errno.ENETDOWN, "x"), "can0")
    assert (
        socketcan_hint(OSError(errno.EPERM, "Operation not permitted"), "can0") == "Operation not permitted"
    )


def test_get_on_a_socketcan_bus_that_cannot_open_is_one_line(capsys):
    code = main(["get", "master", "T_sensor_C", "--bus", "socketcan:ttnone9", "--timeout", "0.2"])
    err = capsys.readouterr().err.strip()
    assert code == EXIT_FAIL and len(err.splitlines()) == 1, err
    assert "cannot open bus socketcan:ttnone9" in err
    assert "no SocketCAN (address family AF_CAN" in err or "no CAN interface 'ttnone9'" in err, err
