"""What bench/nodes_bench.py prints: the table of its runs, the ratios to the raw anchors, late cycles and
the bus load."""

from __future__ import annotations

from typing import Any

from bench.common import print_table

ROW_HEADER = ["run", "cycles", "wall s", "cycles/s", "max |dev| vs offline", "SYNC->TPDO p50 ms", "p99 ms"]


def print_summary(out: dict[str, Any], rows: list, r1k: dict[str, Any]) -> None:
    """The runs' table, the ratios to the anchors, late cycles, bus load and the vcan note."""
    print_table(ROW_HEADER, [[c if c is not None else "n/a" for c in r] for r in rows])
    print_ratios(out)
    print(
        f"late cycles: 100 Hz {out['late_cycles_100hz']}; 1 kHz {r1k['late_cycles']} of {r1k['cycles']} "
        f"({100 * out['late_fraction_1khz']:.2f} %)"
    )
    print(
        f"bus load at 1 Mbit/s: 100 Hz measured {_pct(out['bus_load_1mbit_100hz_measured'])} "
        f"(nominal {_pct(out['bus_load_1mbit_100hz_nominal'])}); 1 kHz measured "
        f"{_pct(out['bus_load_1mbit_1khz_measured'])} (nominal {_pct(out['bus_load_1mbit_1khz_nominal'])})"
    )
    print(f"vcan: {out['lockstep_vcan_note']}")


def print_ratios(out: dict[str, Any]) -> None:
    """Lockstep against the raw ping-pong anchor, in cycles/s and in CPU time per cycle."""
    for t in ("virtual", "hub"):
        print(
            f"lockstep vs raw ping-pong, {t}: {out[f'lockstep_cycles_per_s_{t}']:.0f} / "
            f"{out[f'raw_anchor_cycles_per_s_{t}']:.0f} cycles/s = "
            f"ratio {out[f'lockstep_ratio_vs_raw_{t}']:.2f} "
            "(goal >= 0.75)"
        )
    print(
        "in CPU time of the process, virtual: "
        f"anchor {out['raw_anchor_cpu_us_per_cycle_virtual']:.0f} us / lockstep "
        f"{out['lockstep_cpu_us_per_cycle_virtual']:.0f} us per cycle = "
        f"ratio {out['lockstep_cpu_ratio_vs_raw_virtual']:.2f}"
    )


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100 * x:.2f} %"
