"""The parameters a running node's controller uses: the parameter book (defaults + accepted SDO writes,
:class:`nodes.odparams.ParamBook`), the parameters and the mode in force, the render script's settings,
and the OD image of all of them (what ``telethermo get`` shows).

SDO writes are validated by the book before they are stored (device lock held), go into the book at
once and into the controller at the next SYNC (:meth:`ParamSlot.apply`).
"""

from __future__ import annotations

import dataclasses
import logging
from typing import Callable

from telethermo.device.device import Device, WriteEvent
from telethermo.control.rendering import load_render_table
from telethermo.control.types import Mode, Role

from telethermo.nodes.odparams import GAIN_KEYS, PARAM_KEYS, STORED_KEYS, ParamBook, od_image
from telethermo.nodes.parts import NodeParts
from telethermo.nodes.peer import PeerLink

log = logging.getLogger("telethermo.node")


class ParamSlot:
    """The controller's parameters of one node (``params``, ``mode``), built from its ``book``.

    ``parts``: the defaults (``params_for``), the render script, the period and the finger; ``role``: the
    node's side; ``mode``: the --mode at power-on; ``peer`` gives the node's peer link (a new one at each
    power-on), whose PDO miss limit follows the book."""

    def __init__(self, *, parts: NodeParts, role: Role, mode: Mode, peer: Callable[[], PeerLink]) -> None:
        self._parts = parts
        self._role = role
        self._peer = peer
        self.mode = self.configured_mode = mode
        self.params = None  # built at power-on from the parameter book (defaults + SDO writes)
        self.book: ParamBook | None = None
        self.version = 0
        """The book's version the controller runs."""
        script = parts.render_script
        self.script_rs = script.first if script is not None else None
        self._render_table: dict[str, float] | None = None
        self._w: dict = {}
        self.keys: dict[int, str] = {}
        self.written: dict[str, object] = {}
        """Parameters written since the power-on values, last write last: ``name`` -> value, a gain as
        ``name@MODE`` (each mode has its own); ``mode`` is not kept. What a CiA 301 store saves
        (:mod:`nodes.store_slot`)."""

    def bind(self, dev: Device) -> None:
        """The OD writers of the parameter objects and the book's validators of SDO writes."""
        self._w = {key: dev.writer(key) for key in PARAM_KEYS}
        self.keys = {dev.info.get(key).index: key for key in PARAM_KEYS}  # index -> name
        for key in PARAM_KEYS:
            dev.add_write_validator(key, lambda value, key=key: self.book.check(key, value))

    @property
    def pending(self) -> bool:
        """SDO writes accepted since the controller last took the book."""
        return self.book is not None and self.book.version != self.version

    def power_on(self, dev: Device, *, has_model: bool) -> None:
        """This program's power-on configuration (its --mode, the controller defaults of ``default_params``
        read now): a fresh book from the OD's (EDS) values."""
        if self._render_table is None:
            self._render_table = load_render_table()
        parts = self._parts
        self.book = ParamBook(
            self._role,
            parts.params_for,
            has_model=has_model,
            table=self._render_table,
            od_material=(
                int(dev.read("material_code")),
                float(dev.read("material_beta")),
                float(dev.read("object_T0_C")),
            ),
            script_first=self.script_rs if parts.render_script is not None else None,
            mode=self.configured_mode,
            peer_miss_limit=int(dev.read("peer_pdo_miss_limit")),
        )
        self.mode = self.configured_mode
        self.written = {}
        self.rebuild()

    def rebuild(self) -> None:
        """The controller's parameters from the book now (power-on; after stored values were replayed)."""
        self.params = self.book.params(render=self.scripted_render())
        self.version = self.book.version

    def record(self, tag: str, value) -> None:
        """A parameter write to keep for a store (see :attr:`written`)."""
        self.written.pop(tag, None)
        self.written[tag] = value

    def scripted_render(self):
        """The render script's settings in force (with the operator's pad β / finger temperature),
        or None when the OD's settings are rendered (no script, or the operator chose a material)."""
        if self._parts.render_script is None or not self.book.scripted:
            return None
        return self.book.overlay(self.script_rs)

    def render_view(self):
        """The render settings the OD shows: rendered now (RENDER) or to be rendered."""
        if self.mode is Mode.RENDER:
            return self.params.render
        rs = self.scripted_render()
        return rs if rs is not None else self.book.render_settings()

    def write_image(self) -> None:
        """The parameters in force into their OD objects."""
        rs = self.render_view()
        img = od_image(
            self.params,
            rs,
            material_code=self.book.material_code(rs),
            peer_miss_limit=self.book.peer_miss_limit,
        )
        w = self._w
        for key, value in img.items():
            w[key](value)

    def apply(self) -> None:
        """Take the SDO writes accepted since the last SYNC (called at the start of a SYNC)."""
        book = self.book
        self.version = book.version
        old_mode = self.mode
        try:
            params = book.params(render=self.scripted_render())
        except ValueError as exc:  # the validators refuse what cannot be built: not expected
            log.error("parameters refused at SYNC (%s); keeping the running ones", exc)
            self.write_image()
            return
        self.mode, self.params = book.mode, params
        self._peer().max_missed_cycles = book.peer_miss_limit
        if self.mode is not old_mode:
            log.info("mode %s -> %s", old_mode.name, self.mode.name)
        self.write_image()

    def select_render_touch(self, t_s: float) -> None:
        """The render script's settings in force now (the same script as the offline runner's), unless
        the operator chose the material by SDO; the OD shows them."""
        parts = self._parts
        script = parts.render_script
        if script is not None and self.book.scripted:
            rs = script.settings_at(t_s, parts.period_s, parts.finger_skin)
            if rs is not self.script_rs:
                self.script_rs = rs
                rs = self.book.overlay(rs)
                if rs is not self.params.render:
                    self.params = dataclasses.replace(self.params, render=rs)
                    self.write_image()

    def on_write(self, ev: WriteEvent) -> bool:
        """An accepted SDO write of a parameter (device lock held): into the book now, into the controller at
        the next SYNC. False if ``ev`` is not a parameter's."""
        key = self.keys.get(ev.index)
        if key is None:
            return False
        try:
            self.book.apply(key, ev.value)
        except ValueError as exc:
            log.error("%s = %r not applied: %s", key, ev.value, exc)
            self.book.version += 1  # the next SYNC rewrites the OD with the truth
        else:
            if key in STORED_KEYS:
                self.record(f"{key}@{self.book.mode.name}" if key in GAIN_KEYS else key, ev.value)
        log.info("%s = %r (takes effect at the next SYNC)", key, ev.value)
        return True
