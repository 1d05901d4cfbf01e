"""Settings that survive a restart: the node's CiA 301 store (0x1010) and restore defaults (0x1011),
over :mod:`telethermo.device.storage`.

What a "save" stores, in the node's store file (``--store PATH``; default
``$XDG_STATE_HOME/telethermo/node<ID>.json``, see :func:`telethermo.device.storage.default_store_path`):

- communication (0x1010 sub 2, or sub 1): every writable communication object except 0x1003 (error history),
  0x1005 (SYNC COB-ID: the program's --sync/--no-sync decides who produces SYNC) and 0x1010/0x1011;
- application (sub 3, or sub 1): every parameter the operator wrote by SDO since the power-on values
  (:data:`nodes.odparams.STORED_KEYS`: gains per mode, safety limits, estimator, R_sensor, rendering and
  identification settings, peer_pdo_miss_limit, ...), in the order written, except ``mode`` (the operating
  state: --mode decides it at boot); and the TEM model the controller runs (0x2300..0x2311), if any.

At boot (and at an NMT reset node, which is a reboot of the application) the file is read and checked
(CRC-32); its communication values become the power-on values (NMT resets restore them too), its
parameters are replayed through the same checks as SDO writes (a value refused now is named and its
default kept), its model is loaded as a 0x230D load would (refused: the --model file's stays). The stored
model replaces the --model file's. A file that does not check is refused in one line naming it and the
fault, and the node starts on its defaults. "load" on 0x1011 deletes the group from the file (the whole file
for sub 1): the defaults come back at the next reset or start. 0x2720..0x2722 tell ``telethermo status``
what is in force.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

from telethermo.control.types import Mode
from telethermo.device.device import Device
from telethermo.device.storage import (
    ALL,
    APPLICATION,
    COMMUNICATION,
    GROUPS,
    StoreError,
    StoreFile,
    StoreRestore,
    communication_image,
    install_communication,
)
from telethermo.ident import odmodel
from telethermo.ident.modelfile import ModelFileError

from telethermo.nodes.model_slot import ModelSlot
from telethermo.nodes.odparams import STORED_KEYS
from telethermo.nodes.param_slot import ParamSlot

log = logging.getLogger("telethermo.node")

#: 0x2720 store_state codes
NOT_STORED, RESTORED, REFUSED, SAVED, DEFAULTS_NEXT_RESET = 0, 1, 2, 3, 4


class StoreSlot:
    """The store of one node process: ``bind`` (objects, 0x1010/0x1011), ``load`` before the device starts
    (communication values), ``restore_application`` in every power-on (parameters and model).

    ``settings`` and ``models``: the parameter book and the model slot a store saves and a restore
    replays into; ``period_s``: the control period a stored model must have, s; ``path``: the store file
    of node ``node_id``."""

    def __init__(
        self, *, settings: ParamSlot, models: ModelSlot, period_s: float, node_id: int, path: Path
    ) -> None:
        self._settings = settings
        self._models = models
        self._period_s = period_s
        self._dev: Device | None = None
        self.file = StoreFile(path, node_id)
        self.state = NOT_STORED
        self.saved_unix_s = 0.0
        self._doc: dict | None = None  # the checked content read by load(), for the first power-on
        self._loaded = False
        self._factory: dict[tuple[int, int], bytes] = {}
        self._w: dict = {}

    def bind(self, dev: Device) -> None:
        self._dev = dev
        self._w = {k: dev.writer(k) for k in ("store_state", "store_saved_unix_s", "store_file")}
        self._factory = dict(dev.od_access.defaults)  # the power-on values before a store changed them
        StoreRestore(dev, save=self.save, restore=self.restore_defaults)

    # ------------------------------------------------------------------ boot
    def _read(self) -> dict | None:
        try:
            doc = self.file.read()
        except FileNotFoundError:
            self.state, self.saved_unix_s = NOT_STORED, 0.0
            return None
        except StoreError as exc:
            log.error("store file refused: %s; the defaults are used", exc)
            self.state, self.saved_unix_s = REFUSED, 0.0
            return None
        self.state, self.saved_unix_s = RESTORED, float(doc.get("saved_unix_s") or 0.0)
        return doc

    def load(self, dev: Device) -> None:
        """Before ``dev.start()``: read the store and make its communication values the power-on ones."""
        self._doc = self._read()
        self._loaded = True
        comm = (self._doc or {}).get("communication")
        if comm:
            for note in install_communication(dev, comm, live=True):
                log.warning("%s: stored %s: skipped", self.file.path, note)

    def restore_application(self) -> None:
        """In a power-on (start, NMT reset node), after the parameter book and the model slot have their
        power-on values: the stored model, then the stored parameters."""
        doc = self._doc if self._loaded else self._read()
        self._doc, self._loaded = None, False
        app = (doc or {}).get("application") or {}
        if app.get("model"):
            self._restore_model(app["model"])
        settings = self._settings
        settings.book.has_model = self._models.model is not None
        params = app.get("params") or []
        for item in params:
            if not (isinstance(item, list) and len(item) == 2 and isinstance(item[0], str)):
                log.warning("%s: stored parameter %r: expected [name, value]: skipped", self.file.path, item)
                continue
            self._replay(*item)
        settings.rebuild()
        if doc is not None:
            log.info(
                "store %s (saved %s): %d parameter(s)%s restored",
                self.file.path,
                time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(self.saved_unix_s)),
                len(params),
                " and the model" if app.get("model") else "",
            )
        self.write_status()

    def _replay(self, tag: str, value: Any) -> None:
        key, _, mode_name = tag.partition("@")
        book = self._settings.book
        if (
            key not in STORED_KEYS
            or (mode_name and mode_name not in Mode.__members__)
            or not isinstance(value, (int, float))
            or isinstance(value, bool)
        ):
            log.warning(
                "%s: stored %s = %r is not a parameter of this node: skipped", self.file.path, tag, value
            )
            return
        running = book.mode
        try:
            if mode_name:
                book.mode = Mode[mode_name]  # a gain belongs to the mode it was written in
            code = book.check(key, value)
            if code is None:
                book.apply(key, value)
                self._settings.record(tag, value)
        finally:
            book.mode = running
        if code is not None:
            log.warning(
                "%s: stored %s = %r refused now (abort 0x%08X): its default is kept",
                self.file.path,
                tag,
                value,
                code,
            )

    def _restore_model(self, entries: list) -> None:
        dev, models = self._dev, self._models
        try:
            for index, sub, value in entries:
                dev.write((int(index), int(sub)), value, check=False)
            tem, _ = odmodel.model_from_od(
                lambda i, s: dev.read((i, s)), source=str(self.file.path), period_s=self._period_s
            )
        except (ModelFileError, KeyError, ValueError, TypeError) as exc:
            log.warning("%s: stored model refused (%s): the power-on model is kept", self.file.path, exc)
            models.write_objects(models.model)
            return
        models.model = tem
        models.write_objects(tem)

    # ------------------------------------------------------------------ 0x1010 / 0x1011
    def application_image(self) -> dict:
        """The application group: the written parameters in order and the running model's objects."""
        model = None
        tem = self._models.model
        if tem is not None:
            try:
                model = [[e.index, e.sub, e.value] for e in odmodel.model_entries(tem)]
            except ModelFileError as exc:
                log.warning("the running model is not stored (%s)", exc)
        return {"params": [[tag, value] for tag, value in self._settings.written.items()], "model": model}

    def _existing(self) -> dict:
        try:
            return self.file.read()
        except (FileNotFoundError, StoreError):
            return {}

    def save(self, group: int) -> None:
        """0x1010 sub ``group`` = "save" (device lock held): write the store file atomically."""
        dev = self._dev
        old = self._existing() if group != ALL else {}
        comm = communication_image(dev) if group in (ALL, COMMUNICATION) else old.get("communication")
        app = self.application_image() if group in (ALL, APPLICATION) else old.get("application")
        now = time.time()
        self.file.write(communication=comm, application=app, saved_unix_s=now)
        if group in (ALL, COMMUNICATION):
            install_communication(dev, comm, live=False)  # what the next NMT reset restores
        self.state, self.saved_unix_s = SAVED, now
        self.write_status()
        log.info("parameters saved (%s) to %s", GROUPS[group], self.file.path)

    def restore_defaults(self, group: int) -> None:
        """0x1011 sub ``group`` = "load": the defaults of that group at the next reset or start."""
        dev = self._dev
        if group == ALL:
            self.file.remove()
        else:
            old = self._existing()
            comm = None if group == COMMUNICATION else old.get("communication")
            app = None if group == APPLICATION else old.get("application")
            if comm is None and app is None:
                self.file.remove()
            else:
                self.file.write(
                    communication=comm, application=app, saved_unix_s=old.get("saved_unix_s") or 0.0
                )
        if group in (ALL, COMMUNICATION):
            for key, data in self._factory.items():
                if 0x1000 <= key[0] <= 0x1FFF:
                    dev.od_access.defaults[key] = data
        self.state = DEFAULTS_NEXT_RESET
        self.write_status()
        log.info(
            "defaults (%s) restored in %s: they take effect at the next reset or start",
            GROUPS[group],
            self.file.path,
        )

    def write_status(self) -> None:
        w = self._w
        w["store_state"](self.state)
        w["store_saved_unix_s"](int(self.saved_unix_s) if self.state in (RESTORED, SAVED) else 0)
        w["store_file"](str(self.file.path))
