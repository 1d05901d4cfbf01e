"""benali-khoudja's cooling experiment on the simulator: τ = R·C per material, thickness, back and load.

"We use a method that increases the temperature of each material part (we can fix this temperature to
40 °C) and monitor the temperature variation graph during the cooling phase" (§4, Table 1: with no load
and with a 50 g load). Here: the object (and its load) at 40 °C meets the simulator's finger (at its
steady state in the scene's air) with 6 N at t = 0; the contact face is sampled every 0.1 s for 60 s and
the exponential T_inf + (T_0 − T_inf)·exp(−t/τ) is fitted from 0.5 s on (after the first instant, which
eq. 1 renders). The load is a 50 g brass weight (19 J/K) on the object's back through the contact law at
its own weight (0.49 N). φ = (T_inf − T_finger0)/(T_object0 − T_finger0) goes with τ.

    python -m bench.rc_identify            # writes telethermo/data/render_rc.toml

The render mode reads that file (telethermo.control.later_rc); the simulator is used here only. The
experiment itself is telethermo/offline/rc_cooling.py.
"""

from __future__ import annotations

import sys
from pathlib import Path

from telethermo.atomic import write_text_atomic
from telethermo.control.later_rc import DEFAULT_RC_TABLE
from telethermo.offline.rc_cooling import (
    AMBIENT_C,
    DURATION_S,
    FIT_FROM_S,
    FORCE_N,
    LOAD_G,
    MATERIALS,
    T_HOT_C,
    THICKNESSES_MM,
    identify,
)


def table_toml(rows: list[dict]) -> str:
    """The rows as the render_rc.toml text."""
    head = [
        "# Later-phase RC model (benali-khoudja §4): tau = R*C per material / thickness / back / load,",
        "# identified on the simulator by bench/rc_identify.py "
        "(do not edit: rerun `python -m bench.rc_identify`).",
        f"# Object at {T_HOT_C} °C cooling on the finger ({FORCE_N} N) in {AMBIENT_C} °C air; fit of",
        f"# T_inf + (T_0 - T_inf)*exp(-t/tau) over {FIT_FROM_S}..{DURATION_S} s of the contact face; load = "
        f"{LOAD_G:g} g brass weight on the back.",
        "# final_fraction = (T_inf - T_finger0)/(T_object0 - T_finger0); "
        "fit_rms_C = RMS residual of the fit.",
        "",
    ]
    out = list(head)
    for r in rows:
        out.append("[[entry]]")
        out += [f"{k} = {v!r}" if isinstance(v, str) else f"{k} = {v}" for k, v in r.items()]
        out.append("")
    return "\n".join(out).replace("'", '"')


def run(path: Path = DEFAULT_RC_TABLE, materials: tuple[str, ...] = MATERIALS) -> list[dict]:
    rows = []
    for mname in materials:
        for th in THICKNESSES_MM:
            for load, back in ((0.0, "adiabatic"), (LOAD_G, "adiabatic"), (0.0, "ambient")):
                rows.append(identify(mname, th, load_g=load, back=back))
                r = rows[-1]
                print(
                    f"{mname:16s} {th:5.1f} mm {back:9s} {load:4.0f} g: tau {r['tau_s']:9.3f} s  "
                    f"phi {r['final_fraction']:+.3f}  rms {r['fit_rms_C']:.3f} °C",
                    flush=True,
                )
    write_text_atomic(path, table_toml(rows))
    return rows


def main(argv: list[str] | None = None) -> int:
    run()
    print(f"wrote {DEFAULT_RC_TABLE}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
