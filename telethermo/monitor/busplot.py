"""A picture of a bus log (``telethermo plot FILE.log|.asc|.blf|.trc``): every numeric value the nodes sent
in their PDOs, decoded by their EDS mappings, against time, one panel per unit (°C, W, A, the rest), with
the emergencies (EMCY) marked where they happened. Values without a unit are kept apart by what they are:
8-bit codes (safety state, mode, material: 0..~11) as steps in a panel of their own, wider integers
(``cycle_counter``, tens of thousands) in another, so that neither squashes the other. Pure decoding
here; matplotlib only in :func:`plot_bus_log_png`."""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, field
from typing import Any, Iterable

import can

from telethermo.cia301 import emcy_code_text
from telethermo.monitor.pdo import PdoMap, decode_pdo
from telethermo.units import UNITS, spellings

#: (panel label, spellings of its unit): the units that get a panel of their own
UNIT_PANELS = tuple((UNITS[u].symbol, spellings(u)) for u in ("degC", "W", "A"))
#: the panels in drawing order: the units, then 8-bit codes, counters (wider integers), other numbers
PANELS = ("°C", "W", "A", "code", "count", "other")
PANEL_LABELS = {"code": "state, code", "count": "count", "other": "value"}
WIDTH_IN, ROW_HEIGHT_IN, DPI = 11.0, 2.6, 110


@dataclass
class BusSeries:
    """The decoded log: series[(node name, object name)] = (times s, values), units, EMCYs
    (t s, node, code)."""

    series: dict[tuple[str, str], tuple[list[float], list[float]]] = field(default_factory=dict)
    units: dict[tuple[str, str], str] = field(default_factory=dict)
    panels: dict[tuple[str, str], str] = field(default_factory=dict)  # key -> one of PANELS
    emcys: list[tuple[float, str, int]] = field(default_factory=list)
    frames: int = 0
    pdo_frames: int = 0


def decode_bus_log(messages: Iterable[can.Message], ods: dict[int, Any], names: dict[int, str]) -> BusSeries:
    """Numeric PDO values per node and object (by the EDS mappings), and the EMCYs, from a log's frames."""
    pmap = PdoMap(ods={k: v for k, v in ods.items() if v is not None})
    out = BusSeries()
    t0 = None
    for msg in messages:
        if msg.is_error_frame or msg.is_remote_frame or msg.is_extended_id:
            continue
        t0 = msg.timestamp if t0 is None else t0
        t = msg.timestamp - t0
        out.frames += 1
        cob = msg.arbitration_id
        if 0x081 <= cob <= 0x0FF and len(msg.data) >= 2:
            code = int.from_bytes(bytes(msg.data[:2]), "little")
            if code:
                out.emcys.append((t, names.get(cob - 0x80, f"node {cob - 0x80}"), code))
            continue
        pdef = pmap.lookup(cob)
        if pdef is None or pdef.direction != "TPDO":
            continue
        values, _ = decode_pdo(pdef, bytes(msg.data))
        out.pdo_frames += 1
        who = names.get(pdef.node, f"node {pdef.node}")
        bits = {(e.index, e.subindex): e.bits for e in pdef.entries}
        for v in values:
            if isinstance(v.value, bool) or not isinstance(v.value, (int, float)):
                continue
            key = (who, v.name)
            ts, ys = out.series.setdefault(key, ([], []))
            ts.append(t)
            ys.append(float(v.value))
            out.units[key] = v.unit
            out.panels[key] = _panel_of(v.unit, v.value, bits.get((v.index, v.subindex), 32))
    return out


def _panel_of(unit: str, value: float | int, bits: int) -> str:
    """The panel of a value: its unit's; else an 8-bit integer is a code, a wider one a count."""
    for label, aliases in UNIT_PANELS:
        if unit in aliases:
            return label
    if isinstance(value, int):
        return "code" if bits <= 8 else "count"
    return "other"


def bus_log_figure(data: BusSeries, title: str):
    """A matplotlib Figure: one panel per kind (:data:`PANELS`) with the series of that kind; EMCYs as
    labelled vertical lines. ValueError if nothing numeric was decoded."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    groups: dict[str, list[tuple[str, str]]] = {}
    for key in data.series:
        groups.setdefault(data.panels.get(key, "other"), []).append(key)
    order = [p for p in PANELS if p in groups]
    if not order:
        raise ValueError(
            f"no numeric PDO value in {data.frames} frames (is this the network file the nodes ran "
            "with? their EDS mappings decode the PDOs)"
        )
    fig = Figure(figsize=(WIDTH_IN, ROW_HEIGHT_IN * len(order)), dpi=DPI)
    axs = fig.subplots(len(order), 1, sharex=True, squeeze=False)[:, 0]
    for ax, panel in zip(axs, order):
        for key in sorted(groups[panel]):
            ts, ys = data.series[key]
            finite = [(t, y) for t, y in zip(ts, ys) if math.isfinite(y)]
            if finite and panel == "code":
                ax.step(*zip(*finite), where="post", lw=0.9, label=f"{key[0]} {key[1]}")
            elif finite:
                ax.plot(*zip(*finite), lw=0.9, label=f"{key[0]} {key[1]}")
        for t, who, code in data.emcys:
            ax.axvline(t, color="r", lw=0.8, alpha=0.6)
        ax.set_ylabel(PANEL_LABELS.get(panel, panel))
        if panel in ("code", "count"):
            ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="best", ncol=2)
    for t, who, code in data.emcys[:20]:
        axs[0].annotate(
            f"EMCY {who} 0x{code:04X}",
            (t, 0.98),
            xycoords=("data", "axes fraction"),
            fontsize=6,
            color="r",
            rotation=90,
            va="top",
            ha="right",
        )
    if data.emcys:  # what the codes mean, once each, under the picture
        seen = dict.fromkeys(code for _, _, code in data.emcys)
        fig.text(
            0.01,
            0.005,
            "EMCY: " + "; ".join(f"0x{c:04X} {emcy_code_text(c)}" for c in list(seen)[:6]),
            fontsize=7,
            color="r",
            va="bottom",
        )
    axs[0].set_title(title)
    axs[-1].set_xlabel("time since the first frame s")
    fig.tight_layout()
    return fig


def plot_bus_log_png(data: BusSeries, title: str) -> bytes:
    """PNG bytes of :func:`bus_log_figure`."""
    fig = bus_log_figure(data, title)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()
