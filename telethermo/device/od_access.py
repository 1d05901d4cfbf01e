"""Object dictionary access of a device: local reads and writes by name or number, the SDO write path
(range checks against the EDS, write validators, the communication objects' side effects, write
listeners), live diagnostics objects and the power-on values NMT resets restore.

SDO writes are range-checked against the EDS (REAL32 limits re-read from the text): abort 0x06090030
(range exceeded, or NaN), 0x06090031 (too high), 0x06090032 (too low); the value is left unchanged.
"""

from __future__ import annotations

from typing import Any, Callable, cast

from canopen import objectdictionary as odmod
from canopen import SdoAbortedError

from telethermo.device.canopen_adapter import GatedLocalNode
from telethermo.cia301 import ABORT_GENERAL, ABORT_RANGE
from telethermo.device.context import DeviceCore
from telethermo.device.eds_info import EdsInfo, ObjectKey, VarInfo, parse_index_key
from telethermo.device.events import OdWriteError, WriteEvent
from telethermo.device.settings import DeviceSettings

# diagnostics objects served live from DeviceStats (see bus_config/edsgen.py)
DIAG_OBJECTS = {
    0x2710: "malformed_frames",
    0x2711: "unknown_cobid_frames",
    0x2712: "callback_errors",
    0x2713: "sync_count",
    0x2714: "rpdo_count",
    0x2715: "peer_losses",
}

#: ``hook(index, sub, value, old_bytes)`` after a communication object was stored; an SdoAbortedError
#: refuses the write (the old value is put back)
WriteHook = Callable[[int, int, Any, bytes | None], None]
Slot = tuple[int, int, Any, VarInfo | None]


class OdAccess:
    """Reads and writes of one device's object dictionary."""

    def __init__(self, core: DeviceCore, node: GatedLocalNode, info: EdsInfo, settings: DeviceSettings):
        self.core = core
        self.node = node
        self.info = info
        self.settings = settings
        self.write_listeners: list[Callable[[WriteEvent], None]] = []
        self._validators: dict[tuple[int, int], list[Callable[[Any], int | None]]] = {}
        self._hooks: list[tuple[int, int, WriteHook, Callable[[], None] | None]] = []
        self._slots: dict[ObjectKey, Slot] = {}
        self.defaults = self._power_on_values()
        self.install_defaults(lambda index: True)
        node.add_read_callback(self._on_read)

    # ------------------------------------------------------------------ local access
    def slot(self, key: ObjectKey) -> Slot:
        """(index, sub, ODVariable, VarInfo) of an object named by ``key`` (cached)."""
        slot = self._slots.get(key)
        if slot is None:
            idx = parse_index_key(key)
            if idx is None:
                info = self.info.get(key)  # by name (KeyError if there is none)
            elif (found := self.info.vars.get(idx)) is not None:
                info = found
            else:
                raise KeyError(f"{self.info.path.name}: no object 0x{idx[0]:04X} sub {idx[1]}")
            var = self.node.find(info.index, info.subindex)
            slot = (info.index, info.subindex, var, info)
            self._slots[key] = slot
        return slot

    def read(self, key: ObjectKey) -> Any:
        index, sub, var, _ = self.slot(key)
        return var.decode_raw(self.node.get_data(index, sub))

    def write(self, key: ObjectKey, value: Any, *, check: bool = True) -> None:
        index, sub, var, info = self.slot(key)
        data = var.encode_raw(value)
        if index < 0x2000:
            try:
                self.sdo_write(var, data)
            except SdoAbortedError as exc:
                raise OdWriteError(
                    f"{info.key if info else hex(index)} = {value!r} refused: {exc}", exc.code
                ) from None
            return
        if check and info is not None and (info.low is not None or info.high is not None):
            code = self.info.check(info, var.decode_raw(data))
            if code is not None:
                raise OdWriteError(f"{info.key} = {value!r} is outside {info.range_text()}", code)
        self.core.store[index][sub] = data

    def writer(self, key: ObjectKey) -> Callable[[Any], None]:
        index, sub, var, _ = self.slot(key)
        if index < 0x2000:
            raise ValueError("writer() is for manufacturer objects; use write() for communication objects")
        st = var.STRUCT_TYPES.get(var.data_type)
        cell = self.core.store[index]
        if st is None:
            return lambda value: cell.__setitem__(sub, var.encode_raw(value))
        pack = st.pack
        if var.data_type == odmod.BOOLEAN:
            return lambda value: cell.__setitem__(sub, pack(bool(value)))
        return lambda value: cell.__setitem__(sub, pack(value))

    def reader(self, key: ObjectKey) -> Callable[[], Any]:
        index, sub, var, _ = self.slot(key)
        st = var.STRUCT_TYPES.get(var.data_type)
        if index in DIAG_OBJECTS or st is None:
            return lambda: self.read(key)
        cell, unpack = self.core.store[index], st.unpack
        return lambda: unpack(cell[sub])[0]

    def _on_read(self, index: int, subindex: int, od: odmod.ODVariable) -> Any:
        name = DIAG_OBJECTS.get(index)
        if name is not None:
            return getattr(self.core.stats, name) & 0xFFFFFFFF
        return None

    # ------------------------------------------------------------------ the SDO write path
    def add_validator(self, key: ObjectKey, fn: Callable[[Any], int | None]) -> None:
        index, sub, _, _ = self.slot(key)
        self._validators.setdefault((index, sub), []).append(fn)

    def on_write(
        self, low: int, high: int, hook: WriteHook, *, restore: Callable[[], None] | None = None
    ) -> None:
        """``hook`` applies a write of an object in ``low..high`` (a communication object's side
        effect, run after the value is stored); ``restore()`` after a refused write put the old
        value back."""
        self._hooks.append((low, high, hook, restore))

    def sdo_write(self, var: odmod.ODVariable, data: bytes) -> None:
        """Check, store and apply a write (SDO or local to a communication object)."""
        index, sub = var.index, var.subindex
        info = self.info.vars.get((index, sub))
        value = var.decode_raw(data)
        core = self.core
        with core.lock:
            if var.data_type == odmod.BOOLEAN and data[:1] not in (b"\x00", b"\x01"):
                raise SdoAbortedError(ABORT_RANGE)  # CiA 301 BOOLEAN: 0 FALSE, 1 TRUE, nothing else
            if info is not None and var.data_type in odmod.NUMBER_TYPES:
                code = self.info.check(info, cast("float | int", value))  # a number type decodes to a number
                if code is not None:
                    raise SdoAbortedError(code)
            if self._validators:
                code = self._validate(index, sub, value)
                if code is not None:
                    raise SdoAbortedError(code)
            old = core.store[index].get(sub)
            core.store[index][sub] = data
            self._apply(index, sub, value, old)
            # under the lock, atomically with the store: no SYNC handler runs between the two
            if self.write_listeners:
                core.call(self.write_listeners, WriteEvent(index, sub, value))

    def _apply(self, index: int, sub: int, value: Any, old: bytes | None) -> None:
        for low, high, hook, restore in self._hooks:
            if low <= index <= high:
                break
        else:
            return
        try:
            hook(index, sub, value, old)
        except SdoAbortedError:
            if old is None:
                del self.core.store[index][sub]
            else:
                self.core.store[index][sub] = old
            if restore is not None:
                restore()
            raise

    def _validate(self, index: int, sub: int, value: Any) -> int | None:
        for fn in self._validators.get((index, sub), ()):
            try:
                code = fn(value)
            except Exception:
                self.core.callback_failed(fn)
                return ABORT_GENERAL
            if code is not None:
                return int(code)
        return None

    # ------------------------------------------------------------------ power-on values
    def _power_on_values(self) -> dict[tuple[int, int], bytes]:
        values: dict[tuple[int, int], bytes] = {}
        for obj in self.node.object_dictionary.values():
            members = [obj] if isinstance(obj, odmod.ODVariable) else list(obj.values())
            for var in members:
                raw = var.value if var.value is not None else var.default
                try:
                    data = var.encode_raw(raw) if raw is not None else bytes(max(1, len(var) // 8))
                except Exception:
                    data = bytes(max(1, len(var) // 8))
                values[(var.index, var.subindex)] = data
        for (index, sub), v in self.settings.overrides().items():
            values[(index, sub)] = self.node.find(index, sub).encode_raw(v)
        if self.settings.sync_producer is not None:
            cob = int.from_bytes(values[(0x1005, 0)], "little") & ~(1 << 30)
            cob |= (1 << 30) if self.settings.sync_producer else 0
            values[(0x1005, 0)] = cob.to_bytes(4, "little")
        return values

    def install_defaults(self, which: Callable[[int], bool]) -> None:
        """Put the power-on value back into every object whose index ``which`` accepts."""
        for (index, sub), data in self.defaults.items():
            if which(index):
                self.core.store.setdefault(index, {})[sub] = data
