"""The identification service of a running node (objects 0x2807..0x280B): the progress of the
experiment the controller runs in IDENTIFY mode, and the samples it recorded, fetched one by one by
SDO (``telethermo identify`` reads them as the TPDOs carried them, REAL32).
"""

from __future__ import annotations

import logging

import numpy as np

from telethermo.cia301 import ABORT_NO_DATA
from telethermo.device.device import WriteEvent
from telethermo.control.core import CoreState, StepResult
from telethermo.control.types import Mode
from telethermo.rig import RigSample

from telethermo.nodes.param_slot import ParamSlot
from telethermo.nodes.stats import RuntimeStats

log = logging.getLogger("telethermo.node")

IDENT_NOT_RUN, IDENT_RUNNING, IDENT_DONE, IDENT_INTERRUPTED = 0, 1, 2, 3
_WRITERS = (
    "ident_sample",
    "ident_state",
    "ident_guard",
    "ident_start_cycle",
    "ident_fetched_T_sensor_C",
    "ident_fetched_current_A",
    "ident_fetched_Q_W",
)


class IdentService:
    """The experiment's state (``IDENT_*``) and record: float32 (T_sensor_C, current_A, Q_W) per sample.
    ``settings``: the mode and the experiment's plan in force; ``stats``: the cycle count at its start."""

    def __init__(self, settings: ParamSlot, stats: RuntimeStats) -> None:
        self._settings = settings
        self._stats = stats
        self.state = IDENT_NOT_RUN
        self.record: np.ndarray | None = None
        self._w: dict = {}
        self._fetch_index = -1

    def bind(self, dev) -> None:
        self._w = {name: dev.writer(name) for name in _WRITERS}
        self._fetch_index = dev.info.get("ident_fetch_sample").index
        dev.add_write_validator("ident_fetch_sample", self.check_fetch)

    def power_on(self) -> None:
        self.state = IDENT_NOT_RUN

    def status(self, state: CoreState, sample: RigSample, res: StepResult) -> None:
        """ident_sample / ident_state / ident_guard / ident_start_cycle of this cycle (0x2807..0x280A), and the
        sample kept for ident_fetch_sample (0x280B): the values its TPDOs carry, as REAL32."""
        w, k = self._w, state.ident_k
        w["ident_sample"](k)
        mode = self._settings.mode
        if mode is Mode.IDENTIFY:
            plan = self._settings.params.identify
            total = plan.total
            if k == 1:
                self.record = np.full((total, 3), np.nan, dtype=np.float32)
            if 1 <= k <= total and self.record is not None and len(self.record) == total:
                self.record[k - 1] = (sample.T_sensor_C, res.current_A, res.out.flux_W)
            if k == 1:
                w["ident_start_cycle"](self._stats.cycles & 0xFFFFFFFF)
                log.info("identification experiment started: %d samples (%s)", total, plan.as_dict())
            new = IDENT_DONE if k >= total else IDENT_RUNNING
            if new == IDENT_DONE and self.state == IDENT_RUNNING:
                log.info("identification experiment done: %d samples, %d guarded", k, state.ident_guard)
            w["ident_guard"](state.ident_guard)
        else:
            new = IDENT_INTERRUPTED if self.state == IDENT_RUNNING else self.state
            if new == IDENT_INTERRUPTED and self.state == IDENT_RUNNING:
                log.warning("identification experiment interrupted (mode %s)", mode.name)
        if new != self.state:
            self.state = new
            w["ident_state"](new)

    def check_fetch(self, value) -> int | None:
        """Validator of ident_fetch_sample (0x280B): a sample the last experiment recorded, else 0x08000024."""
        rec = self.record
        j = int(value)
        if rec is None or j >= len(rec) or rec[j, 0] != rec[j, 0]:
            return ABORT_NO_DATA
        return None

    def on_write(self, ev: WriteEvent) -> bool:
        """ident_fetch_sample written (validated): the sample into the ident_fetched_* objects. False if not that object."""
        if ev.index != self._fetch_index:
            return False
        T, I, Q = (float(v) for v in self.record[int(ev.value)])
        w = self._w
        w["ident_fetched_T_sensor_C"](T)
        w["ident_fetched_current_A"](I)
        w["ident_fetched_Q_W"](Q)
        return True
