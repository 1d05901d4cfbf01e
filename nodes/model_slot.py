"""The TEM model a running node's controller uses, and its objects in the OD (0x2300..0x2311,
telethermo.ident.odmodel): shown at power-on, replaced by ``model_command`` (0x230D) at the next SYNC.

``model_command`` = 1 loads the model the objects hold (refused with 0x08000020 if inconsistent, at
another period or unstable; with 0x08000022 while a model-driven controller drives the pad), 2 unloads
it (refused with 0x08000022 while the controller needs a model). Writing a model object after the last
command marks the status EDITED (the objects differ from what runs).
"""

from __future__ import annotations

import logging
from typing import Any, Callable

from telethermo.cia301 import ABORT_APPLICATION as ABORT_MODEL_REFUSED, ABORT_DEVICE_STATE
from telethermo.device.device import Device, WriteEvent
from telethermo.control.core import Feedback
from telethermo.control.estimators import Estimator
from telethermo.control.types import Mode
from telethermo.ident import odmodel
from telethermo.ident.modelfile import ModelFileError

from telethermo.nodes.param_slot import ParamSlot
from telethermo.nodes.parts import NodeParts

log = logging.getLogger("telethermo.node")

MODEL_INDICES = frozenset(range(0x2300, 0x2309)) | frozenset(range(0x230A, 0x2310)) | {0x2310, 0x2311}
"""Objects of the TEM model (telethermo.ident.odmodel) and its command:
0x2309 R_sensor is a controller parameter."""


class ModelSlot:
    """The running ``model`` (the --model file at power-on; 0x230D loads another) and the pending load.

    ``parts``: the --model file's model, the period and the gains fitted to a model; ``settings``: the
    parameter book; ``swap_model(tem, neutral_C)``: the control cycle's predictor takes a new model;
    ``node_id`` names the OD in messages. The device comes by :meth:`bind`."""

    def __init__(
        self, *, parts: NodeParts, settings: ParamSlot, node_id: int, swap_model: Callable[[Any, float], None]
    ) -> None:
        self._parts = parts
        self._settings = settings
        self._node_id = node_id
        self._swap_model = swap_model
        self._dev: Device | None = None
        self.model = parts.model
        self.loaded = 0
        """Models loaded or unloaded by model_command since the start."""
        self._candidate = None  # (TemModel | None, crc) validated by the last model_command write
        self._edited = False  # model objects written since the last model_command
        self._pending = None  # the same, to take at the next SYNC
        self._w: dict = {}

    def bind(self, dev: Device) -> None:
        self._dev = dev
        self._w = {name: dev.writer(name) for name in ("model_status", "model_crc32", "model_command")}
        dev.add_write_validator("model_command", self.check_command)

    @property
    def pending(self) -> bool:
        """A model_command was accepted since the last SYNC."""
        return self._pending is not None

    def power_on(self) -> None:
        """The --model file's model runs again, and the OD shows it."""
        self.model = self._parts.model
        self._candidate = self._pending = None
        self.write_objects(self.model)
        book = self._settings.book
        if book is not None:
            self._parts.fit_model(self.model, book.role)  # and the gains derived from it
            book.version += 1

    def write_objects(self, tem) -> None:
        """The running model into 0x2300..0x2311, its status and CRC (none: status 0, CRC 0)."""
        w = self._w
        if tem is None:
            w["model_status"](odmodel.STATUS_NONE)
            w["model_crc32"](0)
            return
        try:
            entries = odmodel.model_entries(tem)
        except ValueError as exc:  # ModelFileError: more parameters than the objects hold
            log.warning("the model runs but cannot be shown in the OD: %s", exc)
            w["model_status"](odmodel.STATUS_LOADED)
            w["model_crc32"](0)
            return
        for e in entries:
            self._dev.write((e.index, e.sub), e.value, check=False)
        w["model_status"](odmodel.STATUS_LOADED)
        w["model_crc32"](odmodel.od_crc32(entries))

    def check_command(self, value) -> int | None:
        """Validator of model_command (0x230D), device lock held (see the module docstring)."""
        value = int(value)
        book = self._settings.book
        p = book.params() if book is not None else None  # what is requested, not only what runs
        uses_model = p is not None and (p.estimator is not Estimator.FLUX or p.feedback is Feedback.MODEL)
        if value == odmodel.CMD_LOAD:
            if uses_model and book.mode in (Mode.TELEPRESENCE, Mode.RENDER):
                # a new predictor starts at rest: under a model-driven controller its transient would reach
                # the pad (and the peer); swap it while the flux estimator drives, or in idle
                log.warning(
                    "model_command 1 refused: the %s estimator drives the pad in %s",
                    p.estimator.value,
                    book.mode.name,
                )
                return ABORT_DEVICE_STATE
            d = self._dev
            try:
                tem, entries = odmodel.model_from_od(
                    lambda i, s: d.read((i, s)),
                    source=f"node {self._node_id} OD",
                    period_s=self._parts.period_s,
                )
            except ModelFileError as exc:
                log.warning("model_command 1 refused: %s", exc)
                return ABORT_MODEL_REFUSED
            self._candidate = (tem, odmodel.od_crc32(entries))
        elif value == odmodel.CMD_UNLOAD:
            if uses_model:
                log.warning("model_command 2 refused: the estimator %s needs the model", p.estimator.value)
                return ABORT_DEVICE_STATE
            self._candidate = (None, 0)
        else:
            self._candidate = None
        return None

    def on_write(self, ev: WriteEvent) -> bool:
        """An accepted SDO write of a model object or the command (device lock held); False if not one."""
        if ev.index not in MODEL_INDICES:
            return False
        if ev.index == odmodel.COMMAND_INDEX:
            self._pending, self._candidate = self._candidate, None
            self._edited = False
            if self._pending is not None and self._pending[0] is None:
                self._settings.book.has_model = (
                    False  # unloading: no write may select the model estimator now
                )
            self._w["model_command"](0)  # a command, not a setting: reads 0
        else:
            self._edited = True
            if self.model is not None:
                self._w["model_status"](odmodel.STATUS_EDITED)
        return True

    def take(self) -> None:
        """At a SYNC (lock held): run the model loaded by 0x230D from now on."""
        tem, crc = self._pending
        self._pending = None
        self.model = tem
        settings = self._settings
        settings.book.has_model = tem is not None
        parts = self._parts
        parts.fit_model(tem, settings.book.role)  # gains that fit the newly identified rig
        settings.book.version += 1  # the next SYNC rebuilds the parameters with them
        self._swap_model(tem, settings.params.safety.neutral_C)
        status = odmodel.STATUS_LOADED if tem is not None else odmodel.STATUS_NONE
        if tem is not None and self._edited:
            status = (
                odmodel.STATUS_EDITED
            )  # objects written after the load command: they differ from what runs
        self._w["model_status"](status)
        self._w["model_crc32"](crc)
        self._w["model_command"](0)
        self.loaded += 1
        if tem is None:
            log.info("model unloaded")
        else:
            o = tem.temperature.orders
            log.info(
                "model loaded from the OD: orders %d,%d,%d,%d, T_ref %.3f °C, CRC 0x%08X",
                o.n,
                o.m,
                o.p,
                o.q,
                tem.temperature.T_ref_C,
                crc,
            )
            fit = parts.gain_fit
            log.info(
                "gains from the model: x%.3f (gain margin %.1f dB, phase margin %.1f° on the model)",
                fit["rho"],
                fit["margins"]["gain_margin_dB"],
                fit["margins"]["phase_margin_deg"],
            )
