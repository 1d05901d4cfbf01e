"""The identification service of a running node (objects 0x2807..0x280B): the progress of the
experiment the controller runs in IDENTIFY mode, and the samples it recorded, fetched one by one by
SDO (``telethermo identify`` reads them as the TPDOs carried them, REAL32).
"""

from __future__ import annotations

import logging
from typing import Any, Callable

import numpy as np

from telethermo.cia301 import ABORT_NO_DATA
from telethermo.device.device import WriteEvent
from telethermo.control.core import CoreState, StepResult
from telethermo.control.types import Mode
from telethermo.rig import RigSample

from telethermo.nodes.od_publish import RESULT, SAMPLE, OdRow
from telethermo.nodes.param_slot import ParamSlot
from telethermo.nodes.stats import RuntimeStats

log = logging.getLogger("telethermo.node")

IDENT_NOT_RUN, IDENT_RUNNING, IDENT_DONE, IDENT_INTERRUPTED = 0, 1, 2, 3

#: the experiment's progress, written by :meth:`IdentService.status` (0x2807..0x280A)
SAMPLE_NUMBER = OdRow("ident_sample")
STATE = OdRow("ident_state")
GUARD = OdRow("ident_guard")
START_CYCLE = OdRow("ident_start_cycle")
PROGRESS = (SAMPLE_NUMBER, STATE, GUARD, START_CYCLE)
#: the command that fetches one recorded sample (0x280B: written by SDO, validated here)
FETCH_SAMPLE = OdRow("ident_fetch_sample")
#: the record's columns, in order: the field of the cycle each keeps (the value its TPDOs carry) and the
#: object a fetch writes it to (0x280C..0x280E)
RECORD = (
    OdRow("ident_fetched_T_sensor_C", SAMPLE, "T_sensor_C"),
    OdRow("ident_fetched_current_A", RESULT, "current_A"),
    OdRow("ident_fetched_Q_W", RESULT, "out.flux_W"),
)
#: every object the service writes
WRITTEN = (*PROGRESS, *RECORD)


class IdentService:
    """The experiment's state (``IDENT_*``) and record: float32 (T_sensor_C, current_A, Q_W) per sample.
    ``settings``: the mode and the experiment's plan in force; ``stats``: the cycle count at its start."""

    def __init__(self, settings: ParamSlot, stats: RuntimeStats) -> None:
        self._settings = settings
        self._stats = stats
        self.state = IDENT_NOT_RUN
        self.record: np.ndarray | None = None
        self._w: dict[OdRow, Callable[[Any], None]] = {}

    def bind(self, dev) -> None:
        self._w = {row: dev.writer(row.key) for row in WRITTEN}
        dev.add_write_validator(FETCH_SAMPLE.key, self.check_fetch)

    def power_on(self) -> None:
        self.state = IDENT_NOT_RUN

    def status(self, state: CoreState, sample: RigSample, res: StepResult) -> None:
        """ident_sample / ident_state / ident_guard / ident_start_cycle of this cycle (0x2807..0x280A), and
        the sample kept for ident_fetch_sample (0x280B): the values its TPDOs carry, as REAL32."""
        w, k = self._w, state.ident_k
        w[SAMPLE_NUMBER](k)
        mode = self._settings.mode
        if mode is Mode.IDENTIFY:
            plan = self._settings.params.identify
            total = plan.total
            if k == 1:
                self.record = np.full((total, 3), np.nan, dtype=np.float32)
            if 1 <= k <= total and self.record is not None and len(self.record) == total:
                self.record[k - 1] = [row.value(sample if row.source == SAMPLE else res) for row in RECORD]
            if k == 1:
                w[START_CYCLE](self._stats.cycles & 0xFFFFFFFF)
                log.info("identification experiment started: %d samples (%s)", total, plan.as_dict())
            new = IDENT_DONE if k >= total else IDENT_RUNNING
            if new == IDENT_DONE and self.state == IDENT_RUNNING:
                log.info("identification experiment done: %d samples, %d guarded", k, state.ident_guard)
            w[GUARD](state.ident_guard)
        else:
            new = IDENT_INTERRUPTED if self.state == IDENT_RUNNING else self.state
            if new == IDENT_INTERRUPTED and self.state == IDENT_RUNNING:
                log.warning("identification experiment interrupted (mode %s)", mode.name)
        if new != self.state:
            self.state = new
            w[STATE](new)

    def check_fetch(self, value) -> int | None:
        """Validator of ident_fetch_sample (0x280B): a sample the last experiment recorded, else
        0x08000024."""
        rec = self.record
        j = int(value)
        if rec is None or j >= len(rec) or rec[j, 0] != rec[j, 0]:
            return ABORT_NO_DATA
        return None

    def on_write(self, ev: WriteEvent) -> bool:
        """ident_fetch_sample written (validated): the sample into the ident_fetched_* objects (the record's
        columns, :data:`RECORD`). False if not that object."""
        if ev.index != FETCH_SAMPLE.index:
            return False
        w = self._w
        for row, value in zip(RECORD, self.record[int(ev.value)]):
            w[row](float(value))
        return True
