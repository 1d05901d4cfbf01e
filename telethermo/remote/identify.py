"""A remote node's identification service (0x2800..0x280E) and model objects (0x2300..0x2311), client side.

The plan is written by SDO (:func:`write_plan`); the samples come on three synchronous TPDOs
(:data:`STREAM`, CiA 301 dynamic mapping), each carrying the sample number with one value, into a
:class:`Stream`; a value lost on the bus is fetched again by SDO from the node's record
(:func:`fetch_lost`); an identified model is loaded by SDO and its CRC-32 checked (:func:`load_model`).
"""

from __future__ import annotations

import struct
import threading
import time
from typing import Callable

import numpy as np

from telethermo.ident import odmodel
from telethermo.ident.modelfile import TemModel
from telethermo.ident.plan import IdentifyPlan
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure

#: the identification stream: (communication, mapping) record of TPDO2..4 and their mapping (index << 16 |
#: sub << 8 | bits): the sample number (ident_sample, U32) with one REAL32 value each
STREAM = (
    (0x1801, 0x1A01, [0x28070020, 0x20000020]),  # ident_sample, T_sensor_C
    (0x1802, 0x1A02, [0x28070020, 0x20020020]),  # ident_sample, current_A
    (0x1803, 0x1A03, [0x28070020, 0x20010020]),
)  # ident_sample, Q_W
FIELDS = ("T_sensor_C", "current_A", "Q_W")
IDENT_STATE_NAMES = {0: "not run", 1: "running", 2: "done", 3: "interrupted"}


class Stream:
    """The experiment's values as they arrive: each frame carries a sample number and one value (field f of
    :data:`FIELDS`, by COB-ID). A sample is complete when all three fields arrived."""

    def __init__(self, cobs: list[int], total: int) -> None:
        self.field_of = {cob: f for f, cob in enumerate(cobs)}
        self.total = total
        self.values = np.full((3, total), np.nan)
        self.got = np.zeros((3, total), dtype=bool)
        self.count = 0
        self.complete = 0  # samples with all three values
        self.duplicates = 0
        self.highest = 0
        self.cond = threading.Condition()

    @property
    def T_C(self) -> np.ndarray:
        return self.values[0]

    @property
    def I_A(self) -> np.ndarray:
        return self.values[1]

    @property
    def Q_W(self) -> np.ndarray:
        return self.values[2]

    @property
    def seen(self) -> np.ndarray:
        """Samples with all three values."""
        return self.got.all(axis=0)

    def on_frame(self, can_id: int, data: bytearray, timestamp: float) -> None:
        f = self.field_of.get(can_id)
        if f is None or len(data) != 8:
            return
        k, v = struct.unpack("<If", data)
        if not 1 <= k <= self.total:
            return  # not (or no longer) in the experiment
        j = k - 1
        with self.cond:
            repeated = bool(self.got[f, j])
            if repeated:
                self.duplicates += 1
            self.values[f, j] = v
            self.got[f, j] = True
            self.count += 1
            if not repeated and self.got[0, j] and self.got[1, j] and self.got[2, j]:
                self.complete += 1
            self.highest = max(self.highest, k)
            self.cond.notify_all()

    def missing(self) -> int:
        return int(self.total - self.seen.sum())

    def fill(self, j: int, T_C: float, I_A: float, Q_W: float) -> None:
        """Sample ``j`` fetched by SDO (a value of it lost on the bus)."""
        with self.cond:
            self.values[:, j] = (T_C, I_A, Q_W)
            self.got[:, j] = True


def write_plan(client: NodeClient, plan: IdentifyPlan) -> None:
    """The plan into the node's objects 0x2800..0x2806, range-checked (the maximum amplitude is raised first
    where the new minimum would exceed the node's present maximum)."""
    lo, hi = plan.amplitude_A
    for key, value in (
        ("ident_seed", plan.seed),
        ("ident_rest_samples", plan.rest_samples),
        ("ident_train_samples", plan.train_samples),
        ("ident_validation_samples", plan.validation_samples),
        ("ident_amplitude_max_A", max(hi, float(client.get("ident_amplitude_min_A")))),
        ("ident_amplitude_min_A", lo),
        ("ident_amplitude_max_A", hi),
        ("ident_hold_samples", plan.hold_samples),
    ):
        client.set(key, value)


def fetch_lost(
    stream: Stream, client: NodeClient, plan: IdentifyPlan, notice: Callable[[str], None] | None = None
) -> int:
    """Samples lost on the bus (a busy computer's CAN socket overflows; a real bus can drop frames too)
    fetched again by SDO from the node's record of the experiment (0x280B..0x280E). Returns how many; Failure
    when so many are lost (over a fifth) that the stream is not worth patching. ``notice`` is told how many it
    fetches."""
    lost = np.flatnonzero(~stream.seen)
    if not len(lost):
        return 0
    if len(lost) > max(100, plan.total // 5):
        raise Failure(
            f"{len(lost)} of {plan.total} samples lost on the bus: too many to fetch again by SDO; "
            "nothing fitted or loaded (a less loaded computer, or real time, helps)"
        )
    if notice is not None:
        notice(f"{len(lost)} of {plan.total} samples lost on the bus; fetching them by SDO ...")
    for j in lost.tolist():
        client.set("ident_fetch_sample", j)
        stream.fill(
            j,
            float(client.get("ident_fetched_T_sensor_C")),
            float(client.get("ident_fetched_current_A")),
            float(client.get("ident_fetched_Q_W")),
        )
    return len(lost)


#: how long the node may take to run a written model, s: it is taken at the node's next SYNC, but a node on
#: a loaded computer (two CPU hogs beside a VM's bus) missed 5 s once; a longer wait costs nothing otherwise
LOAD_TIMEOUT_S = 30.0


def load_model(client: NodeClient, tem: TemModel, timeout_s: float = LOAD_TIMEOUT_S) -> int:
    """Write ``tem`` into the node's model objects by SDO, load it (0x230D = 1) and check the node's CRC-32 of
    the model it then runs (0x230F) against the CRC of what was written, polling for up to ``timeout_s``
    seconds. Returns the CRC; Failure otherwise."""
    entries = odmodel.model_entries(tem)
    for e in entries:
        client.set((e.index, e.sub), e.value)
    client.set("model_command", odmodel.CMD_LOAD)
    want = odmodel.od_crc32(entries)
    deadline = time.monotonic() + timeout_s
    while True:  # taken at the node's next SYNC
        status, crc = int(client.get("model_status")), int(client.get("model_crc32"))
        if status == odmodel.STATUS_LOADED and crc == want:
            return crc
        if time.monotonic() > deadline:
            raise Failure(
                f"{client.t.role}: the model was sent but the node runs CRC-32 0x{crc:08X} "
                f"(status {odmodel.STATUS_NAMES.get(status, status)}), not 0x{want:08X}"
            )
        time.sleep(0.05)
