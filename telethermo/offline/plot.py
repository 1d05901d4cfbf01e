"""The session plot, like guiatni Fig. 10: both sides' temperatures and the direct-touch reference.

One plot for every recording in the telethermo.recording.format format: an offline or two-process
session's ``recording.csv`` (both sides and the reference) and one node's ``--record`` CSV (``m_*``
or ``s_*`` columns only). Rows, each drawn only when the recording has data for it: (1) master: the
finger's skin on the pad (truth), the measured sensor temperature, the master's finger estimate T_f,
its target T_o (from the slave; the setpoint when rendering) and the direct-touch reference;
(2) slave: its object estimate T_o, its target T_f, its true pad surface and its sensor; (3) heat
flux: into the finger, telepresence vs direct touch (truth), or, without truth (hardware, a slave's
recording), each side's measured sensor flux; (4) the currents; (5) contact detected by each
controller and each side's safety state (telethermo.control.safety.SafetyState, by name). Touches
of the scene are shaded. Written atomically as PNG (matplotlib, Agg backend).
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Callable

import numpy as np

from telethermo.atomic import write_bytes_atomic
from telethermo.control.safety import SafetyState
from telethermo.offline.figures import contacts_of
from telethermo.recording.format import Recording

WIDTH_IN, ROW_HEIGHT_IN, DPI = 11.0, 2.6, 100
SIDES = (("m", "master", "C1"), ("s", "slave", "C2"))


def _legend(ax) -> None:
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=7)


def _has(rec: Recording, *names: str) -> bool:
    return any(np.isfinite(rec.col(n)).any() for n in names)


def _touches(rec: Recording) -> list[tuple[float, float]]:
    """The shaded spans: the scene's touches as session.png shows them (:func:`contacts_of`: the probe's
    touches in telepresence, the display's when rendering). A master's own recording in telepresence
    has none (its finger rests on the pad throughout): nothing is shaded."""
    return [(c["t_on_s"], c["t_off_s"]) for c in contacts_of(rec)]


def _title(rec: Recording) -> str:
    meta = rec.meta
    render = meta.get("mode") == "render"
    what = "virtual rendering" if render else str(meta.get("mode") or "telepresence")
    node = f"{meta['role']} node {meta.get('node_id', '?')}, " if meta.get("role") else ""
    return (
        f"{meta.get('scene', '')}: {what} ({node}period {meta.get('period_s')} s, "
        f"rounding {meta.get('rounding', 'none')})"
    )


def _line(ax, rec: Recording, name: str, label: str, **kw) -> None:
    y = rec.col(name)
    if np.isfinite(y).any():
        kw.setdefault("lw", 1.0)
        ax.plot(rec.col("t_s"), y, label=label, **kw)


def _master_temps(ax, rec: Recording) -> None:
    render = rec.meta.get("mode") == "render"
    _line(ax, rec, "m_true_surface_C", "finger skin on the pad (truth)", color="C3")
    _line(ax, rec, "m_T_sensor_C", "master sensor (measured)", color="0.5", lw=0.8)
    _line(ax, rec, "m_estimate_C", "master estimate T_f", color="C1", ls="--")
    _line(
        ax,
        rec,
        "m_target_C" if not render else "m_setpoint_C",
        "master target" if not render else "setpoint",
        color="C0",
        ls=":",
    )
    _line(ax, rec, "ref_T_contact_C", "direct touch (reference)", color="k")
    ax.set_ylabel("master °C")


def _slave_temps(ax, rec: Recording) -> None:
    _line(ax, rec, "s_estimate_C", "slave estimate T_o", color="C2", ls="--")
    _line(ax, rec, "s_target_C", "slave target (T_f)", color="C0", ls=":")
    _line(ax, rec, "s_true_surface_C", "probe pad surface (truth)", color="C4")
    _line(ax, rec, "s_T_sensor_C", "slave sensor (measured)", color="0.5", lw=0.8)
    ax.set_ylabel("slave °C")


def _flux_columns(rec: Recording) -> tuple[str, list[str]]:
    """The heat across the contact into the finger (truth); older recordings only have the sensor's flux."""
    q_col = "m_true_Q_into_body_W" if _has(rec, "m_true_Q_into_body_W") else "m_true_Q_W"
    q_cols = [q_col, "ref_Q_into_finger_W"] if _has(rec, q_col) else [f"{p}_Q_W" for p, _, _ in SIDES]
    return q_col, q_cols


def _flux(ax, rec: Recording) -> None:
    q_col, q_cols = _flux_columns(rec)
    if _has(rec, q_col):
        _line(ax, rec, q_col, "into the finger (telepresence)", color="C3")
        _line(ax, rec, "ref_Q_into_finger_W", "into the finger (direct touch)", color="k")
    else:  # no simulator truth: what the sensors measured (> 0 out of the pad)
        for p, side, colour in SIDES:
            _line(ax, rec, f"{p}_Q_W", f"{side} sensor flux (measured)", color=colour)
    # the direct touch's first samples are near-singular (semi-infinite contact: q ~ 1/sqrt(t)); scale the
    # axis to the bulk of the curves so the telepresence flux stays readable
    both = np.concatenate([rec.col(c) for c in q_cols])
    both = both[np.isfinite(both)]
    if both.size:
        lo, hi = np.percentile(both, [0.5, 99.5])
        pad = 0.1 * max(hi - lo, 0.1)
        ax.set_ylim(lo - pad, hi + pad)
    ax.set_ylabel("flux W")


def _currents(ax, rec: Recording) -> None:
    _line(ax, rec, "m_current_A", "master current", color="C1")
    _line(ax, rec, "s_current_A", "slave current", color="C2")
    ax.set_ylabel("current A")


def _states(ax, rec: Recording) -> None:
    t = rec.col("t_s")
    for p, side, colour in SIDES:
        c = rec.col(f"{p}_contact")
        if np.isfinite(c).any():
            ax.fill_between(
                t,
                0,
                np.nan_to_num(c) > 0.5,
                step="post",
                color=colour,
                alpha=0.15,
                lw=0,
                transform=ax.get_xaxis_transform(),
                label=f"{side} contact detected",
            )
        s = rec.col(f"{p}_safety_state")
        if np.isfinite(s).any():
            ax.step(t, s, where="post", color=colour, lw=1.2, label=f"{side} safety state")
    ax.set_yticks([int(s) for s in SafetyState], [s.name for s in SafetyState], fontsize=7)
    ax.set_ylim(-0.3, max(SafetyState) + 0.3)
    ax.set_ylabel("contact, safety")


def _panels(rec: Recording) -> list[tuple[Callable, tuple[str, ...]]]:
    """The panels that have data: (draw(ax, rec), the columns it shows)."""
    render = rec.meta.get("mode") == "render"
    panels: list[tuple[Callable, tuple[str, ...]]] = [
        (
            _master_temps,
            (
                "m_true_surface_C",
                "m_T_sensor_C",
                "m_estimate_C",
                "m_target_C",
                "m_setpoint_C",
                "ref_T_contact_C",
            ),
        ),
        (_slave_temps, () if render else ("s_estimate_C", "s_target_C", "s_true_surface_C", "s_T_sensor_C")),
        (_flux, tuple(_flux_columns(rec)[1])),
        (_currents, ("m_current_A", "s_current_A")),
        (_states, ("m_contact", "m_safety_state", "s_contact", "s_safety_state")),
    ]
    return [(draw, cols) for draw, cols in panels if _has(rec, *cols)]


def plot_session_png(rec: Recording) -> bytes:
    """PNG bytes of the plot of ``rec`` (a session's or one node's recording)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    t = rec.col("t_s")
    panels = _panels(rec)
    if not panels:
        raise ValueError(
            "the recording has no signal to plot (no temperature, flux, current or state column "
            "with a number)"
        )
    fig = Figure(figsize=(WIDTH_IN, ROW_HEIGHT_IN * len(panels)), dpi=DPI)
    axs = np.atleast_1d(fig.subplots(len(panels), 1, sharex=True))
    spans = _touches(rec)
    for ax, (draw, _) in zip(axs, panels):
        for on, off in spans:
            ax.axvspan(on, off, color="0.9", zorder=0)
        ax.grid(True, alpha=0.3)
        draw(ax, rec)
        _legend(ax)
    axs[0].set_title(_title(rec))
    axs[-1].set_xlabel("time s")
    if len(t) > 1 and t[-1] > t[0]:  # the scene's touches may go on after a shortened run
        axs[-1].set_xlim(t[0], t[-1])
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def write_session_png(path: str | os.PathLike, rec: Recording) -> Path:
    """Write the session plot to ``path`` atomically."""
    return write_bytes_atomic(path, plot_session_png(rec))
