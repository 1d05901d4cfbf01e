"""The rendering benchmark's later-phase figures (telethermo/offline/later_phase_figures.py; quick: aluminium
1 mm and 20 mm) say what they should: on the foil the conduction model follows the direct touch far better
than eq. 1 alone and than a null display; on the block (semi-infinite for 10 s) the three models render nearly
the same first second."""

from __future__ import annotations

import json

from telethermo.offline.later_phase_figures import later_phase_figures


def test_later_phase_figures_quick():
    figs = later_phase_figures(quick=True)
    json.dumps(figs)  # JSON-ready: the coordinator merges it into rendering.json
    rows = {(r["material"], r["thickness_mm"], r["model"]): r for r in figs["later_phase"]}
    assert len(rows) == 8
    foil = {m: rows[("aluminium", 1.0, m)] for m in ("semi_infinite", "rc", "conduction", "null_hold_preset")}
    assert foil["conduction"]["late_C"] < foil["semi_infinite"]["late_C"] / 4
    assert foil["conduction"]["late_C"] < foil["rc"]["late_C"] < foil["semi_infinite"]["late_C"]
    assert foil["conduction"]["late_C"] < foil["null_hold_preset"]["late_C"] / 4
    block = [rows[("aluminium", 20.0, m)]["early_C"] for m in ("semi_infinite", "rc", "conduction")]
    assert max(block) - min(block) < 0.01
    assert (
        rows[("aluminium", 20.0, "conduction")]["late_C"]
        <= rows[("aluminium", 20.0, "semi_infinite")]["late_C"]
    )
