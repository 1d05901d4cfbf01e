"""Figures of an identification run, after guiatni Fig. 3-5: capacity fit (Fig. 3), measured vs
estimated temperature (Fig. 4) and heat flux (Fig. 5) on the held-out PRBS. Needs matplotlib (extra
'plot')."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from telethermo.atomic import write_bytes_atomic
from telethermo.ident.modelfile import TemModel


def plot_identification(path: str | os.PathLike[str], tem: TemModel, report: dict[str, Any]) -> Path:
    """Write a PNG with the held-out temperature and flux (measured vs free-run model) and, if measured,
    the capacity points and fit. ``report`` must come from ``identify_rig(..., keep_record=True)``."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rec = report.get("record")
    if rec is None:
        raise ValueError("the report has no record: run identify_rig(..., keep_record=True)")
    ss = report.get("steady_states")
    n = 3 if ss is not None and tem.capacity is not None else 2
    fig, axes = plt.subplots(n, 1, figsize=(9, 3.2 * n), constrained_layout=True)
    k0 = int(rec["n_fit"])
    t = rec["t_s"][k0:]
    ax = axes[0]
    ax.plot(t, rec["T_C"][k0:], lw=1.0, label="measured (sensor)")
    ax.plot(t, rec["T_pred_C"][k0:], "--", lw=1.0, label="model, free run")
    o = tem.temperature.orders
    ax.set(
        xlabel="t (s)",
        ylabel="T (°C)",
        title=f"held-out PRBS: temperature, NARMA {o.n},{o.m},{o.p},{o.q}; "
        f"worst {report['heldout_free_run_max_C']:.3f} °C (cf. guiatni Fig. 4)",
    )
    ax.legend(loc="upper right")
    ax = axes[1]
    ax.plot(t, rec["Q_W"][k0:], lw=1.0, label="measured")
    ax.plot(t, rec["Q_pred_W"][k0:], "--", lw=1.0, label="model, free run")
    ax.set(
        xlabel="t (s)",
        ylabel="Q (W)",
        title=f"held-out PRBS: heat flux; worst {report['flux_heldout_max_W']:.4f} W (cf. guiatni Fig. 5)",
    )
    ax.legend(loc="upper right")
    if ss is not None and tem.capacity is not None:  # n == 3
        ax = axes[2]
        ax.plot(ss.current_A, ss.Q_W, "o", label="measured steady states")
        I = np.linspace(ss.current_A.min(), ss.current_A.max(), 200)
        T = np.interp(I, ss.current_A, ss.T_C)
        ax.plot(I, tem.capacity.predict(current_A=I, T_C=T), "-", label="eq. 13 fit")
        ax.set(
            xlabel="I (A)",
            ylabel="P (W), heat out of the pad",
            title="steady-state capacity (cf. guiatni Fig. 3)",
        )
        ax.legend(loc="upper left")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return write_bytes_atomic(path, buf.getvalue())
