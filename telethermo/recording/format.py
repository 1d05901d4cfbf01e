"""The session recording: one row per control step, one documented CSV format for every path.

The offline runner (telethermo.offline.runner) and the two-process node session write the same
format, so :func:`telethermo.offline.figures.compute_figures` works on either.

File layout (UTF-8, ``\\n`` line ends)::

    # telethermo-recording 1
    # meta {"scene": "...", "period_s": 0.01, ...}       <- one line of JSON (see META below)
    t_s,m_T_sensor_C,m_Q_W,...                         <- header: column names (see COLUMNS)
    0.01,33.0012,0.0213,...                            <- one row per step

Numbers are written with ``repr`` precision (round-trip exact); booleans as 0/1; NaN as ``nan``;
text columns (``*_limits``, ``*_new_trips``) hold names joined by ``|`` (empty when none).
Unknown extra columns are kept; missing optional columns are NaN/empty on read.

Columns (prefix ``m_`` master, ``s_`` slave; per side):

=================== ====== ==========================================================================
name                unit   meaning
=================== ====== ==========================================================================
t_s                 s      sample time (the rigs' clock)
sync_cycle          int    node recordings and their merge only (not in COLUMNS; the offline runner has
                           none): the SYNC the row belongs to, the producer's SYNCs numbered from 0 alike
                           on both nodes; -1 for a slave's local fallback cycle (recording.merge joins on it)
X_T_sensor_C        °C     thermocouple at the flux sensor's mid-plane (measured, filtered)
X_Q_W               W      heat flux through the sensor, > 0 out of the pad (measured, filtered)
X_T_sink_C          °C     heat-sink temperature (measured)
X_current_A         A      current commanded by the controller in this step (after the envelope)
X_target_C          °C     what the mode asked to track (telepresence: the peer's estimate); NaN if none
X_setpoint_C        °C     the setpoint after the safety envelope
X_feedback_C        °C     what the PI compared with the setpoint
X_estimate_C        °C     the estimate sent to the peer (master: finger T_f, slave: object T_o)
X_T_pred_C          °C     the TEM model's prediction (NaN without a model)
X_peer_estimate_C   °C     the peer's estimate as received (after REAL32 rounding on a bus)
X_peer_flux_W       W      the peer's flux as received
X_contact           0/1    contact detected by the controller from the signals
X_safety_state      int    telethermo.control.safety.SafetyState
X_error_register    int    CiA 301 object 0x1001
X_limits                   envelope limits that acted ("ramp|guard|current_limit|...")
X_new_trips                trips raised in this step ("peer_lost|...")
X_true_surface_C    °C     truth: the contact-side surface (master: the finger's skin on the pad)
X_true_Q_W          W      truth: heat flux through the contact, > 0 out of the pad
X_true_Q_into_body_W W     truth: heat flow across the contact into what touches the pad (master: into the
                           finger's skin, < 0 when the pad draws heat from it); 0 when nothing touches
X_true_touching     0/1    truth: something touches the pad (scene schedule)
m_true_finger_C     °C     truth: the operator's skin on the master, touching or not (in air between)
ref_T_contact_C     °C     truth: direct-touch reference, the finger's skin (on the object, or in air)
ref_Q_into_finger_W W      truth: heat flux into the finger in the reference (< 0: loses heat; 0 in air)
ref_touching        0/1    truth: the reference finger touches the object
=================== ====== ==========================================================================

META keys: ``scene`` (name), ``period_s``, ``mode`` ("telepresence" | "render"), ``rounding``
("none" | "real32"), ``contacts`` (list of {"t_on_s", "t_off_s", "object"}: the scene's touches of
the probe (telepresence) or of the display (render)), ``render`` (render mode: list of
{"material", "beta", "T_contact_C", "T_pad0_C", "T_finger0_C", "T_object0_C"} per touch) and any
further descriptive keys (params, seeds, versions).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from telethermo.recording.journal import CsvRecorder

MAGIC = "# telethermo-recording 1"

SIDE_NUMERIC = [
    "T_sensor_C",
    "Q_W",
    "T_sink_C",
    "current_A",
    "target_C",
    "setpoint_C",
    "feedback_C",
    "estimate_C",
    "T_pred_C",
    "peer_estimate_C",
    "peer_flux_W",
    "contact",
    "safety_state",
    "error_register",
    "true_surface_C",
    "true_Q_W",
    "true_Q_into_body_W",
    "true_touching",
]
SIDE_TEXT = ["limits", "new_trips"]
REF_NUMERIC = ["m_true_finger_C", "ref_T_contact_C", "ref_Q_into_finger_W", "ref_touching"]
TEXT_COLUMNS = frozenset(f"{p}_{c}" for p in ("m", "s") for c in SIDE_TEXT)
COLUMNS = ["t_s"] + [f"{p}_{c}" for p in ("m", "s") for c in SIDE_NUMERIC + SIDE_TEXT] + REF_NUMERIC
SYNC_CYCLE = "sync_cycle"
"""The column of a node recording that says which SYNC the row belongs to (-1: a local fallback cycle)."""


def node_columns(p: str) -> list[str]:
    """The columns of one node's recording (``p``: ``"m"`` master, ``"s"`` slave): ``t_s``,
    :data:`SYNC_CYCLE` and the side's ``p_*`` columns of :data:`COLUMNS`, in their order."""
    return ["t_s", SYNC_CYCLE] + [c for c in COLUMNS if c.startswith(f"{p}_")]


class RecordingError(ValueError):
    """A recording file that cannot be read: the message names the file, the line and the field."""


@dataclass
class Recording:
    """A recorded session: ``meta`` (dict) and ``columns`` (name -> 1-D numpy array or list of str)."""

    meta: dict[str, Any]
    columns: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.columns.get("t_s", ()))

    def col(self, name: str) -> np.ndarray:
        """A numeric column as float array (NaN-filled if absent)."""
        if name in self.columns:
            return np.asarray(self.columns[name], dtype=float)
        return np.full(len(self), np.nan)

    def text(self, name: str) -> list[str]:
        """A text column (empty strings if absent)."""
        if name in self.columns:
            return list(self.columns[name])
        return [""] * len(self)


class RecordingBuilder:
    """Collects rows step by step (lists), then :meth:`build` makes numpy columns."""

    def __init__(self, meta: dict[str, Any]) -> None:
        self.meta = dict(meta)
        self._cols: dict[str, list[Any]] = {c: [] for c in COLUMNS}

    def add(self, row: dict[str, Any]) -> None:
        """Append one step; columns missing from ``row`` get NaN (or '' for text)."""
        for c, lst in self._cols.items():
            v = row.get(c)
            if c in TEXT_COLUMNS:
                lst.append(v if v is not None else "")
            else:
                lst.append(math.nan if v is None else float(v))

    def build(self) -> Recording:
        cols: dict[str, Any] = {}
        for c, lst in self._cols.items():
            cols[c] = list(lst) if c in TEXT_COLUMNS else np.asarray(lst, dtype=float)
        return Recording(meta=self.meta, columns=cols)


def _fmt(v: Any) -> str:
    if isinstance(v, str):
        return v
    f = float(v)
    if math.isnan(f):
        return "nan"
    if f.is_integer() and abs(f) < 1e15:
        return str(int(f))
    return repr(f)


def header_comments(meta: dict[str, Any], *, allow_nan: bool = False) -> list[str]:
    """The comment lines that open a recording (without their ``# ``): the magic line and the meta
    (``allow_nan``: write a NaN in the meta as JSON's ``NaN`` extension instead of refusing it, as the
    nodes' recordings always have)."""
    return [MAGIC[2:], "meta " + json.dumps(meta, allow_nan=allow_nan, sort_keys=True, default=str)]


def _rows(rec: Recording) -> Iterator[list[str]]:
    cols = list(rec.columns.values())
    for i in range(len(rec)):
        yield [_fmt(c[i]) for c in cols]


def write_recording_csv(path: str | os.PathLike[str], rec: Recording) -> Path:
    """Write ``rec`` to ``path`` atomically, through the recordings' one writer
    (:class:`telethermo.recording.journal.CsvRecorder`, as the nodes)."""
    head = header_comments(rec.meta, allow_nan=True)  # as the nodes: a NaN parameter (e.g. no tau) is kept
    writer = CsvRecorder(path, list(rec.columns), comments=head, flush_every=1 << 30)
    try:
        for row in _rows(rec):
            writer.write(row)
    except BaseException:
        writer.abort()
        raise
    return writer.close()


def read_recording_csv(path: str | os.PathLike[str]) -> Recording:
    """Read a recording; :class:`RecordingError` names the file, line and column on bad input."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read: {exc}") from exc
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:  # a binary file, or a write torn inside a character
        line = raw.count(b"\n", 0, exc.start) + 1
        raise RecordingError(f"{path}: line {line}: not UTF-8 text (byte 0x{raw[exc.start]:02X})") from None
    lines = text.split("\n")
    if not lines or lines[0].strip() != MAGIC:
        raise RecordingError(f"{path}: line 1: expected {MAGIC!r}, got {lines[0][:60]!r}")
    if len(lines) < 3 or not lines[1].startswith("# meta "):
        raise RecordingError(f"{path}: line 2: expected '# meta {{json}}'")
    try:
        meta = json.loads(lines[1][len("# meta ") :])
    except json.JSONDecodeError as exc:
        raise RecordingError(f"{path}: line 2: meta is not valid JSON: {exc}") from exc
    if not isinstance(meta, dict):
        raise RecordingError(f"{path}: line 2: meta must be a JSON object")
    reader = csv.reader(io.StringIO("\n".join(lines[2:])))
    try:
        rows = list(reader)
    except csv.Error as exc:  # e.g. a field longer than the csv module's limit (a torn or foreign file)
        raise RecordingError(f"{path}: line {reader.line_num + 2}: not a CSV row ({exc})") from None
    if not rows:
        raise RecordingError(f"{path}: line 3: expected the header row")
    header = rows[0]
    if "t_s" not in header:
        raise RecordingError(f"{path}: line 3: header has no 't_s' column")
    if len(set(header)) != len(header):
        raise RecordingError(f"{path}: line 3: duplicate column names")
    cols: dict[str, Any] = {h: [] for h in header}
    for ln, r in enumerate(rows[1:], start=4):  # file line numbers (blank lines count, rows skip them)
        if not r:
            continue
        if len(r) != len(header):
            raise RecordingError(f"{path}: line {ln}: expected {len(header)} fields, got {len(r)}")
        for h, v in zip(header, r):
            if h in TEXT_COLUMNS:
                cols[h].append(v)
            else:
                try:
                    cols[h].append(float(v))
                except ValueError:
                    raise RecordingError(
                        f"{path}: line {ln}: column {h!r}: expected a number, got {v!r}"
                    ) from None
    out = {h: (v if h in TEXT_COLUMNS else np.asarray(v, dtype=float)) for h, v in cols.items()}
    return Recording(meta=meta, columns=out)
