"""Rendering benchmark: the render mode's later-phase models against the simulator's direct touch.

Per virtual object (material, thickness; adiabatic back, at the 25 °C ambient): the master alone renders
one 10 s touch at 6 N (yamamoto eq. 7 pre-set, then eq. 1 at contact) with each later-phase model
(telethermo.control.later_phase: ``semi_infinite`` = the behaviour before issue 15, ``rc`` =
benali-khoudja §4, ``conduction`` = the few-cell model of the object), plus a null display that pre-sets
its pad as eq. 7 asks for the object and then holds its current through the touch (it ignores the
object). The figure is the RMS of the operator's skin temperature minus the same finger's skin when it
touches the same object directly (sim.build_reference), over 0-1 s (early_C) and 1-10 s (late_C) after
the touch.

    python -m bench.rendering_bench [--quick]
        # -> bench/results/rendering.json key later_phase, rendering.png

``later_phase_figures(quick)`` (telethermo/offline/later_phase_figures.py) returns the later-phase figures;
``run`` measures the slave's material identification in the same run (bench/material_id_bench.py) and writes
both into rendering.json. It also measures the graceful link loss (bench/link_loss_bench.py):
``link_loss_fallback_error_C`` and ``link_loss_neutral_ramp_error_C`` (the skin error while the slave is lost
during a touch, with the fallback and with the ramp to neutral as before), ``link_loss`` (per object).
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path
from typing import Any

import numpy as np

from bench.common import current_results_dir, print_table, write_results
from bench.link_loss_bench import print_figures
from bench.material_id_bench import material_id_figures, print_material_id
from telethermo.atomic import write_bytes_atomic
from telethermo.offline.later_phase_figures import (
    MODELS,
    NULL,
    TOUCH_S,
    T_ON_S,  # noqa: F401
    later_phase_figures,  # noqa: F401  (re-exported)
    measure,
)
from telethermo.offline.link_loss import link_loss_figures


def write_plot(path: Path, traces: dict) -> Path | None:
    """Skin temperature vs time for Al 1 mm and Al 20 mm: direct touch and the three models."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = [k for k in (("aluminium", 1.0), ("aluminium", 20.0)) if k in traces]
    if not keys:
        return None
    fig, axes = plt.subplots(1, len(keys), figsize=(6 * len(keys), 4), sharey=True)
    for ax, key in zip(np.atleast_1d(axes), keys):
        tr = traces[key]
        t = tr["t"] - T_ON_S
        m = (t >= -1.0) & (t <= TOUCH_S)
        ax.plot(t[m], tr["direct"][m], "k", lw=2, label="direct touch (simulator)")
        for model, style in zip((*MODELS, NULL), ("C0-", "C1--", "C2-", "C7:")):
            ax.plot(t[m], tr[model][m], style, label=model)
        ax.set_title(f"aluminium {key[1]:g} mm (adiabatic back)")
        ax.set_xlabel("time since touch (s)")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel("operator's skin temperature (°C)")
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return write_bytes_atomic(path, buf.getvalue())


def run(quick: bool) -> dict[str, Any]:
    """Measure the later phase and the slave's material identification in one run, print both, write
    rendering.json and rendering.png; the data."""
    rows, traces = measure(quick)
    print_table(
        ["material", "mm", "model", "early RMS °C", "late RMS °C"],
        [[r["material"], r["thickness_mm"], r["model"], r["early_C"], r["late_C"]] for r in rows],
    )
    mat = material_id_figures(quick)
    print_material_id(mat)
    out_dir = current_results_dir()
    data: dict[str, Any] = {"quick": quick, "later_phase": rows, **mat}
    link = link_loss_figures(quick)
    print_figures(link)
    data.update(link)
    print(f"wrote {write_results('rendering', data)}")
    png = write_plot(out_dir / "rendering.png", traces)
    if png:
        print(f"wrote {png}")
    return data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.rendering_bench", description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="Al 1 mm and 20 mm only")
    run(ap.parse_args(argv).quick)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
