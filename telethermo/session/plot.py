"""The session plot, like guiatni Fig. 10: both sides' temperatures and the direct-touch reference.

Rows: (1) master: the finger's skin on the pad (truth), the master's finger estimate T_f, its target
T_o (from the slave) and the direct-touch reference; (2) slave: its object estimate T_o, its target
T_f and its true pad surface; (3) heat flux into the finger, telepresence vs direct touch; (4) the
currents. Touches are shaded. Written atomically as PNG (matplotlib, Agg backend).
"""
from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from telethermo.atomic import write_bytes_atomic
from telethermo.session.figures import contacts_of
from telethermo.session.recording import Recording


def _legend(ax) -> None:
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=7)


def plot_session_png(rec: Recording) -> bytes:
    """PNG bytes of the session plot."""
    import matplotlib
    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    t = rec.col("t_s")
    render = rec.meta.get("mode") == "render"
    rows = 3 if render else 4
    fig = Figure(figsize=(11, 2.6 * rows), dpi=100)
    axs = fig.subplots(rows, 1, sharex=True)
    contacts = contacts_of(rec)
    for ax in axs:
        for c in contacts:
            ax.axvspan(c["t_on_s"], c["t_off_s"], color="0.9", zorder=0)
        ax.grid(True, alpha=0.3)

    def line(ax, name, label, **kw):
        y = rec.col(name)
        if np.isfinite(y).any():
            ax.plot(t, y, label=label, lw=1.0, **kw)

    ax = axs[0]
    line(ax, "m_true_surface_C", "finger skin on the pad (truth)", color="C3")
    line(ax, "m_estimate_C", "master estimate T_f", color="C1", ls="--")
    line(ax, "m_target_C" if not render else "m_setpoint_C", "master target" if not render else "setpoint",
         color="C0", ls=":")
    line(ax, "ref_T_contact_C", "direct touch (reference)", color="k")
    ax.set_ylabel("master °C")
    ax.set_title(f"{rec.meta.get('scene', '')}: {'virtual rendering' if render else 'telepresence'}"
                 f" (period {rec.meta.get('period_s')} s, rounding {rec.meta.get('rounding', 'none')})")
    _legend(ax)
    k = 1
    if not render:
        ax = axs[k]
        line(ax, "s_estimate_C", "slave estimate T_o", color="C2", ls="--")
        line(ax, "s_target_C", "slave target (T_f)", color="C0", ls=":")
        line(ax, "s_true_surface_C", "probe pad surface (truth)", color="C4")
        ax.set_ylabel("slave °C")
        _legend(ax)
        k += 1
    ax = axs[k]
    # the heat across the contact into the finger (truth); older recordings only have the sensor's flux
    q_col = "m_true_Q_into_body_W" if np.isfinite(rec.col("m_true_Q_into_body_W")).any() else "m_true_Q_W"
    line(ax, q_col, "into the finger (telepresence)", color="C3")
    line(ax, "ref_Q_into_finger_W", "into the finger (direct touch)", color="k")
    # the direct touch's first samples are near-singular (semi-infinite contact: q ~ 1/sqrt(t)); scale the
    # axis to the bulk of both curves so the telepresence flux stays readable
    both = np.concatenate([rec.col(q_col), rec.col("ref_Q_into_finger_W")])
    both = both[np.isfinite(both)]
    if both.size:
        lo, hi = np.percentile(both, [0.5, 99.5])
        pad = 0.1 * max(hi - lo, 0.1)
        ax.set_ylim(lo - pad, hi + pad)
    ax.set_ylabel("flux W")
    _legend(ax)
    ax = axs[k + 1]
    line(ax, "m_current_A", "master current", color="C1")
    line(ax, "s_current_A", "slave current", color="C2")
    ax.set_ylabel("current A")
    ax.set_xlabel("time s")
    _legend(ax)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def write_session_png(path: str | os.PathLike, rec: Recording) -> Path:
    """Write the session plot to ``path`` atomically."""
    return write_bytes_atomic(path, plot_session_png(rec))
