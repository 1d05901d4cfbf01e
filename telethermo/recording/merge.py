"""Merging the two nodes' recordings into one session recording (telethermo.recording.format
format), so that ``compute_figures`` gives the same figures as for an offline session.

Each node records its own side (``m_*`` or ``s_*`` columns, with ``t_s`` and ``sync_cycle``). The
rows are matched by the SYNC cycle they belong to (``sync_cycle``, both nodes number the SYNCs alike
from the SYNC counter, nodes.runtime): a row of one side whose cycle the other side did not record
(the slave was killed or restarted, a SYNC the master sent while the slave was not OPERATIONAL) is
dropped, and so is a slave's local fallback cycle (``sync_cycle`` -1: it belongs to no SYNC). The
master's ``t_s`` is the time axis. Recordings without ``sync_cycle`` (written before it existed) are
matched row by row, checking that ``t_s`` agrees (both simulated rigs start at t = 0 and advance one
period per SYNC). The direct-touch reference (``ref_*``) and the scene's contacts are added from the
scene, as the offline runner does: the reference is physics only, no controller.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from telethermo.sim import build_reference, load_scene
from telethermo.recording.format import (
    COLUMNS,
    SYNC_CYCLE,
    TEXT_COLUMNS,
    Recording,
    RecordingError,
    read_recording_csv,
)
from telethermo.recording.rows import ref_row, scene_contacts


class MergeError(ValueError):
    """The two recordings do not belong together (names the files and what differs)."""


def merge_recordings(
    master_csv: str | Path, slave_csv: str | Path | None, *, scene: Any = None, reference: bool = True
) -> Recording:
    """One recording from the master's and (optionally) the slave's files, plus the scene's reference.

    Rows are cut to the shorter file (a node stopped a cycle earlier). ``scene``: a loaded scene or a
    path (None: no reference columns and no contacts in the meta).
    """
    m = read_recording_csv(master_csv)
    s = read_recording_csv(slave_csv) if slave_csv is not None else None
    n_master = len(m)
    if SYNC_CYCLE in m.columns and (s is None or SYNC_CYCLE in s.columns):
        mi, si = _join_on_cycle(m, s)
    else:
        n = len(m) if s is None else min(len(m), len(s))
        mi = si = np.arange(n)
        if s is not None:
            t, ts = m.col("t_s")[:n], s.col("t_s")[:n]
            bad = np.flatnonzero(np.abs(t - ts) > 1e-9)
            if bad.size:
                k = int(bad[0])
                raise MergeError(
                    f"{master_csv} and {slave_csv}: row {k}: t_s {t[k]} s vs {ts[k]} s "
                    "(the rigs are not in lockstep)"
                )
    n = len(mi)
    t = m.col("t_s")[mi]
    meta = {k: v for k, v in m.meta.items() if k not in ("role", "node_id", "seed")}
    meta["seeds"] = {"master": m.meta.get("seed"), **({"slave": s.meta.get("seed")} if s is not None else {})}
    meta["mode"] = m.meta.get("mode", "telepresence")
    cols: dict[str, Any] = {"t_s": t}
    for rec, idx in ((m, mi), (s, si)):
        if rec is None or idx is None:
            continue
        for c, v in rec.columns.items():
            if c != "t_s":
                cols[c] = [v[i] for i in idx] if c in TEXT_COLUMNS else np.asarray(v, dtype=float)[idx]
    if scene is not None:
        sc = load_scene(scene) if isinstance(scene, (str, Path)) else scene
        meta["contacts"] = scene_contacts(sc, "slave" if meta["mode"] == "telepresence" else "master")
        if reference:
            ref = build_reference(sc)
            period = float(meta.get("period_s") or sc.period_s)
            rows = []
            for _ in range(n_master if n else 0):  # the master's rows are consecutive periods of its rig
                rows.append(ref_row(ref))
                ref.advance(period)
            for c in ("ref_T_contact_C", "ref_Q_into_finger_W", "ref_touching"):
                cols[c] = np.asarray([r[c] for r in rows], dtype=float)[mi]
    for c in COLUMNS:  # the documented column set, NaN/empty where a side is absent
        if c not in cols:
            cols[c] = [""] * n if c in TEXT_COLUMNS else np.full(n, math.nan)
    ordered = {c: cols[c] for c in COLUMNS}
    ordered.update({c: v for c, v in cols.items() if c not in ordered})
    return Recording(meta=meta, columns=ordered)


def _join_on_cycle(m: Recording, s: Recording | None) -> tuple[np.ndarray, np.ndarray | None]:
    """Row indices of the master and the slave recording with the same SYNC cycle, in the master's
    order (fallback cycles, -1, and cycles only one side recorded left out; a cycle recorded twice
    by one side, which a counter restart can give, counts once: its first row)."""
    mc = m.col(SYNC_CYCLE)
    if s is None:
        keep = np.flatnonzero(np.isfinite(mc) & (mc >= 0))
        return keep, None
    first: dict[float, int] = {}
    for j, c in enumerate(s.col(SYNC_CYCLE)):
        if c >= 0 and c not in first:
            first[c] = j
    mi, si, seen = [], [], set()
    for i, c in enumerate(mc):
        at = first.get(c)
        if at is not None and c not in seen:
            seen.add(c)
            mi.append(i)
            si.append(at)
    return np.asarray(mi, dtype=int), np.asarray(si, dtype=int)


__all__ = ["merge_recordings", "MergeError", "RecordingError", "SYNC_CYCLE"]
