"""The socketcand protocol's wire format, the subset python-can's ``socketcand`` client uses (raw mode,
after socketcand's ``doc/protocol.md``), as the hub (:mod:`telethermo.transport.hub`) speaks it.

Messages::

    hub  -> client   < hi >                      on connect
    client -> hub    < open CHANNEL >            hub answers < ok >
    client -> hub    < rawmode >                 hub answers < ok >; from now on the client receives
    hub  -> client   < frame ID SEC.USEC HEX >   ID: 3 hex digits (11-bit) or 8 (29-bit);
                                                 HEX: data, no spaces
    client -> hub    < send ID DLC B0 B1 ... >   DLC and bytes in hex
"""

from __future__ import annotations


def parse_send(command: str) -> tuple[str, bytes] | None:
    """Parse the body of ``< send ID DLC B0 ... >`` (without the brackets) into (ID text, data).

    The ID text keeps its width (3 hex digits = 11-bit, 8 = 29-bit) so the frame goes out in the
    same format. Returns None for a malformed command (bad ID, DLC > 8 or not matching the bytes).
    """
    parts = command.split()
    if len(parts) < 3 or parts[0] != "send":
        return None
    can_id, dlc_text, byte_texts = parts[1], parts[2], parts[3:]
    try:
        ident = int(can_id, 16)
        dlc = int(dlc_text, 16)
        data = bytes(int(b, 16) for b in byte_texts)
    except ValueError:
        return None
    if len(can_id) == 3:
        if ident > 0x7FF:
            return None
    elif len(can_id) == 8:
        if ident > 0x1FFFFFFF:
            return None
    else:
        return None
    if not (0 <= dlc <= 8) or dlc != len(data):
        return None
    return can_id.upper(), data


def format_frame(can_id: str, data: bytes, timestamp_s: float) -> bytes:
    """``< frame ID SEC.USEC HEX >`` as socketcand sends it."""
    sec = int(timestamp_s)
    usec = int((timestamp_s - sec) * 1e6)
    return f"< frame {can_id} {sec}.{usec:06d} {data.hex().upper()} >".encode("ascii")
