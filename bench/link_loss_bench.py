"""Graceful link loss (issue 15): the operator's skin while the slave is lost during a touch, as a table.

The scenes, runs and figures are telethermo/offline/link_loss.py's (the skin against the simulator's direct
touch of the same object; its docstring describes them).

    python -m bench.link_loss_bench [--quick]      # prints the table (rendering_bench writes the figures)
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from bench.common import print_table
from telethermo.offline.link_loss import link_loss_figures


def print_figures(figs: dict[str, Any]) -> None:
    print_table(
        ["material", "fallback RMS °C", "neutral ramp RMS °C", "no loss RMS °C"],
        [
            [r["material"], r["fallback_C"], r["neutral_ramp_C"], r["telepresence_C"]]
            for r in figs["link_loss"]
        ],
    )
    print(
        f"link_loss_fallback_error_C {figs['link_loss_fallback_error_C']}  "
        f"link_loss_neutral_ramp_error_C {figs['link_loss_neutral_ramp_error_C']}"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.link_loss_bench", description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="carbon steel and oak only")
    print_figures(link_loss_figures(ap.parse_args(argv).quick))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
