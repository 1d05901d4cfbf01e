"""CiA 301 store parameters (0x1010) and restore default parameters (0x1011), and the store file.

The objects (CiA 301 v4.2 §7.5.2.13/14), sub-index 1 all parameters, 2 communication parameters
(0x1000..0x1FFF), 3 application parameters (0x6000..0x9FFF in CiA 301; on our nodes the manufacturer
parameters 0x2000..): reading gives the capability bits (bit 0: the device saves on command; bit 1:
autonomously, never here), so each reads 0x00000001. Writing the signature "save" (0x65766173, the
ASCII bytes s, a, v, e little-endian) stores that group; writing "load" (0x64616F6C) to 0x1011
restores the defaults, which take effect at the next reset (NMT reset node / reset communication) or
boot, as CiA 301 says. Any other value is refused with abort 0x08000020 (as CANopenNode's CO_storage
does); a store that cannot be written is refused with 0x06060000 (hardware error).

:class:`StoreRestore` is the protocol part on a :class:`~telethermo.device.device.Device`; what is
stored and how it is put back is the program's (its ``save(group)`` / ``restore(group)``).
:class:`StoreFile` is the file: one JSON document per node, written atomically
(:mod:`telethermo.atomic`) with a CRC-32 over its canonical content, read through
:func:`telethermo.inputfile.load_json` and refused whole (with one line naming the file, the field and what
was wrong) when it does not check.
"""

from __future__ import annotations

import json
import os
import re
import zlib
from pathlib import Path
from typing import Any, Callable

from canopen.sdo import SdoAbortedError

from telethermo.atomic import write_json_atomic
from telethermo.cia301 import ABORT_APPLICATION, ABORT_HARDWARE
from telethermo.device.device import Device
from telethermo.inputfile import ABSENT, InputFileError, load_json

STORE_INDEX, RESTORE_INDEX = 0x1010, 0x1011
SAVE_SIGNATURE = 0x65766173  # "save"
LOAD_SIGNATURE = 0x64616F6C  # "load"
ALL, COMMUNICATION, APPLICATION = 1, 2, 3
GROUPS = {ALL: "all", COMMUNICATION: "communication", APPLICATION: "application"}
CAPABILITY_ON_COMMAND = 0x00000001
#: communication objects a store does not hold: the error history (0x1003), SYNC COB-ID and producer role
#: (0x1005: the program's --sync option decides), and the store/restore objects themselves
NOT_STORED = frozenset({0x1003, 0x1005, STORE_INDEX, RESTORE_INDEX})
FORMAT = "telethermo-store 1"


class StoreError(InputFileError):
    """A store file that cannot be used: one line naming the file, the field and what was expected
    (``file: field 'F': expected E[, got G]``; an error of the whole file or a line: ``file: problem``)."""

    @classmethod
    def at(cls, file: str | Path, field: str, expected: str, got: Any = ABSENT) -> StoreError:
        got_text = "" if got is ABSENT else f", got {got!r}"
        return cls(f"{file}: field '{field}': expected {expected}{got_text}", file, field)


class StoreRestore:
    """0x1010/0x1011 on ``dev``: ``save(group)`` on a "save" write to 0x1010 sub ``group``, ``restore(group)``
    on a "load" write to 0x1011 (group: :data:`ALL`, :data:`COMMUNICATION`, :data:`APPLICATION`).

    Both run in the SDO write path (notifier thread, device lock held) before the SDO response goes out;
    an exception (OSError, StoreError) refuses the write with 0x06060000. The objects read back their
    capability bits whatever was written.
    """

    def __init__(self, dev: Device, *, save: Callable[[int], None], restore: Callable[[int], None]) -> None:
        self.dev = dev
        self._actions = {STORE_INDEX: save, RESTORE_INDEX: restore}
        signatures = {STORE_INDEX: SAVE_SIGNATURE, RESTORE_INDEX: LOAD_SIGNATURE}
        for index, signature in signatures.items():

            def refuse(v: Any, s: int = signature) -> int | None:  # anything but the signature
                return None if int(v) == s else ABORT_APPLICATION

            for sub in GROUPS:
                dev.add_write_validator((index, sub), refuse)
        dev.od_access.on_write(STORE_INDEX, RESTORE_INDEX, self._written)

    def _written(self, index: int, sub: int, value: Any, old: bytes | None) -> None:
        # the signature was stored by the write path: the object reads its capability again
        self.dev.core.store[index][sub] = CAPABILITY_ON_COMMAND.to_bytes(4, "little")
        try:
            self._actions[index](sub)
        except (OSError, StoreError) as exc:
            raise SdoAbortedError(ABORT_HARDWARE) from exc


def default_store_path(node_id: int) -> Path:
    """``$XDG_STATE_HOME/telethermo/node<ID>.json`` (``~/.local/state`` when XDG_STATE_HOME is unset)."""
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "telethermo" / f"node{node_id}.json"


def _crc(body: dict[str, Any]) -> int:
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return zlib.crc32(text.encode()) & 0xFFFFFFFF


class StoreFile:
    """The store of one node: ``{"format", "node_id", "saved_unix_s", "communication", "application",
    "crc32"}``, sections ``None`` when not stored. ``crc32`` is the CRC-32 of the other keys as canonical
    JSON (sorted keys, no spaces)."""

    def __init__(self, path: str | os.PathLike[str], node_id: int) -> None:
        self.path = Path(path)
        self.node_id = node_id

    def exists(self) -> bool:
        return self.path.is_file()

    def read(self) -> dict[str, Any]:
        """The checked content. StoreError naming the file and the fault (unreadable, not JSON, wrong format,
        checksum mismatch, another node's file, a field of the wrong type); FileNotFoundError if there is
        none."""
        try:
            doc = load_json(self.path, f"the store file of node {self.node_id}", StoreError)
        except StoreError:
            if not self.path.exists():
                raise FileNotFoundError(2, "no store file", str(self.path)) from None
            raise
        if doc.get("format", None) != FORMAT:
            raise doc.fail("format", repr(FORMAT), doc.get("format", ABSENT))
        crc = doc.get("crc32", None)
        if not isinstance(crc, str) or not re.fullmatch(r"0x[0-9A-Fa-f]{8}", crc):
            raise doc.fail("crc32", "a hex checksum '0x........'", doc.get("crc32", ABSENT))
        body = {k: v for k, v in doc.raw.items() if k != "crc32"}
        actual = _crc(body)
        if int(crc, 16) != actual:
            raise StoreError(
                f"{self.path}: field 'crc32': checksum {crc} does not match the content "
                f"(0x{actual:08X}): the file was changed or damaged",
                self.path,
                "crc32",
            )
        doc.int("node_id", expected=f"{self.node_id} (this node's ID)", lo=self.node_id, hi=self.node_id)
        if doc.get("saved_unix_s", None) is not None:
            doc.float("saved_unix_s", lo=0.0, unit=" s")
        for key in ("communication", "application"):
            if doc.get(key, None) is not None:
                doc.table(key, expected="an object or null")
        return body

    def write(
        self, *, communication: dict[str, Any] | None, application: dict[str, Any] | None, saved_unix_s: float
    ) -> None:
        """Atomically replace the file (OSError if it cannot be written)."""
        body = {
            "format": FORMAT,
            "node_id": self.node_id,
            "saved_unix_s": round(float(saved_unix_s), 3),
            "communication": communication,
            "application": application,
        }
        write_json_atomic(self.path, dict(body, crc32=f"0x{_crc(body):08X}"))

    def remove(self) -> bool:
        """Delete the file; True if there was one."""
        try:
            self.path.unlink()
        except FileNotFoundError:
            return False
        return True


def communication_image(dev: Device) -> dict[str, str]:
    """``"0xIIII:S" -> hex bytes`` of every writable communication object a store holds (see NOT_STORED)."""
    out: dict[str, str] = {}
    for (index, sub), info in sorted(dev.info.vars.items()):
        writable = info.access in ("rw", "rww", "rwr", "wo")
        if 0x1000 <= index <= 0x1FFF and index not in NOT_STORED and writable:
            data = dev.core.store.get(index, {}).get(sub)
            if data is not None:
                out[f"0x{index:04X}:{sub}"] = bytes(data).hex()
    return out


def install_communication(dev: Device, image: dict[str, str], *, live: bool) -> list[str]:
    """Make ``image`` (of :func:`communication_image`) the power-on values that NMT resets restore; with
    ``live`` also the values now (before ``dev.start()``: the services configure themselves from them).
    Returns one note per entry that does not fit this EDS (skipped)."""
    notes = []
    for key, text in image.items():
        try:
            idx, _, sub = key.partition(":")
            index, subindex = int(idx, 16), int(sub)
            data = bytes.fromhex(text)
        except ValueError:
            notes.append(f"{key}: not an object key with hex bytes")
            continue
        info = dev.info.vars.get((index, subindex))
        old = dev.od_access.defaults.get((index, subindex))
        if info is None or old is None or len(old) != len(data) or index in NOT_STORED:
            notes.append(f"{key}: not a stored object of {dev.info.path.name} (or another size)")
            continue
        dev.od_access.defaults[(index, subindex)] = data
        if live:
            dev.core.store.setdefault(index, {})[subindex] = data
    return notes
