"""Draw docs/img/wiring.png: the bench wiring of one telepresence pair on standard CANopen I/O modules
(docs/hardware.md). Run from the checkout: ``.venv/bin/python scripts/wiring_diagram.py``."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyBboxPatch  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "docs" / "img" / "wiring.png"


def box(ax, x, y, w, h, text, color):
    ax.add_patch(
        FancyBboxPatch((x, y), w, h, boxstyle="round,pad=0.02,rounding_size=0.08", fc=color, ec="k", lw=1)
    )
    ax.text(x + w / 2, y + h / 2, text, ha="center", va="center", fontsize=8)


def wire(ax, x0, y0, x1, y1, text="", color="k", style="-"):
    ax.annotate(
        "", xy=(x1, y1), xytext=(x0, y0), arrowprops=dict(arrowstyle="->", color=color, ls=style, lw=1.2)
    )
    if text:
        ax.text(x0 - 0.06, (y0 + y1) / 2, text, ha="right", va="center", fontsize=7, color=color)


def side(ax, x0, title, node_pc, node_io, pad):
    box(ax, x0, 5.2, 3.2, 0.8, f"{title} PC\n{node_pc}", "#dde8f7")
    box(
        ax,
        x0,
        3.4,
        3.2,
        0.9,
        f"CiA 401/404 I/O module (node {node_io})\n6 analog in 0x6401 (16 bit, 10 ms)\n1 analog out 0x6411",
        "#e6f2e0",
    )
    box(ax, x0 - 0.1, 1.6, 1.0, 0.8, "thermocouple\namplifier\n100 mV/°C", "#fff3d6")
    box(ax, x0 + 1.1, 1.6, 1.0, 0.8, "heat-flux\namplifier\n1 V/W", "#fff3d6")
    box(ax, x0 + 2.3, 1.6, 1.0, 0.8, "bipolar current\namplifier\n1 A/V, ±I_max", "#fde0dc")
    box(
        ax,
        x0,
        0.1,
        3.2,
        0.9,
        f"{pad}\nTEM + flux sensor (thermocouple at mid-plane)\nheat sink (thermistor)",
        "#eeeeee",
    )
    wire(ax, x0 + 0.4, 1.0, x0 + 0.4, 1.6)
    wire(ax, x0 + 1.6, 1.0, x0 + 1.6, 1.6)
    wire(ax, x0 + 2.8, 1.6, x0 + 2.8, 1.0, color="#b03020")
    wire(ax, x0 + 0.4, 2.4, x0 + 0.4, 3.4, "T, T_sink")
    wire(ax, x0 + 1.6, 2.4, x0 + 1.6, 3.4, "Q")
    wire(ax, x0 + 2.8, 3.4, x0 + 2.8, 2.4, "I cmd", color="#b03020")
    wire(ax, x0 + 3.1, 2.4, x0 + 3.1, 3.4)
    ax.text(x0 + 3.16, 2.9, "I mon", ha="left", va="center", fontsize=7)


def main() -> None:
    fig, ax = plt.subplots(figsize=(11, 6.2))
    ax.set_xlim(-0.5, 9.5)
    ax.set_ylim(-0.2, 7.2)
    ax.axis("off")
    side(
        ax,
        0.2,
        "master",
        "telethermo-master (node 1)\n--rig io --rig-config RIG.toml",
        3,
        "display: the operator's fingertip",
    )
    side(
        ax,
        5.6,
        "slave",
        "telethermo-slave (node 2)\n--rig io --rig-config RIG.toml",
        4,
        "probe: the robot finger + force sensor",
    )
    ax.plot([-0.3, 9.3], [4.8, 4.8], color="#5a2d82", lw=4)
    ax.text(
        4.5,
        4.88,
        "CAN bus, 1 Mbit/s, 120 Ω at both ends: SYNC 100 Hz (node 1), TPDOs of the modules on "
        "SYNC, RPDO of each drive, heartbeats, EMCY (measured load 12.6 %)",
        ha="center",
        fontsize=7.5,
        color="#5a2d82",
    )
    for x in (1.8, 7.2):
        ax.plot([x, x], [4.3, 4.8], color="#5a2d82", lw=2)
        ax.plot([x, x], [4.8, 5.2], color="#5a2d82", lw=2)
    ax.text(
        4.5,
        6.7,
        "One telepresence pair on standard CANopen I/O modules (docs/hardware.md)",
        ha="center",
        fontsize=11,
        weight="bold",
    )
    ax.text(
        4.5,
        6.35,
        "the module cuts its output to 0 A by itself when node 1/2's heartbeat stops "
        "(0x1016 consumer 150 ms, 0x6443 = 1, 0x6444 = code of 0 A)",
        ha="center",
        fontsize=8,
        color="#b03020",
    )
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, dpi=110, bbox_inches="tight")


if __name__ == "__main__":
    main()
