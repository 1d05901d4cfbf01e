"""The PDO layout as a DBC file (``telethermo dbc``), so that cantools and CAN viewers decode our traffic.

One message (``BO_``) per valid TPDO of the network file's nodes, from their EDS mapping as the monitor
reads it (:class:`telethermo.monitor.pdo.PdoMap`): transmitter the producing node, each mapped object a
little-endian signal (``@1``) at its bit offset, signed for INTEGERn and REAL, IEEE floats declared by
``SIG_VALTYPE_`` (1 = REAL32, 2 = REAL64), the unit from the EDS, receivers the nodes whose RPDO has the same
COB-ID. Material codes get a value table (``VAL_``) from the rendering table, and each signal a comment
(``CM_``) naming its object. A DBC file is a static picture: a PDO remapped at run time is not in it.
"""

from __future__ import annotations

import re
from typing import Any

from canopen.objectdictionary import datatypes as dt

from telethermo.control.render_table import load_render_table

from .material import ABSTAIN_CODE
from .pdo import MATERIAL_CODE_OBJECTS, PdoMap

_NAME = re.compile(r"[^A-Za-z0-9_]")


def dbc_name(text: str) -> str:
    """A DBC identifier (C-like: letters, digits, underscore, not starting with a digit)."""
    name = _NAME.sub("_", text) or "_"
    return f"_{name}" if name[0].isdigit() else name


def _quote(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', "'")


def dbc_text(ods: dict[int, Any], names: dict[int, str]) -> str:
    """The DBC text of the TPDOs of ``ods`` (node-ID -> canopen ObjectDictionary), nodes named by
    ``names``."""
    pmap = PdoMap(ods={k: v for k, v in ods.items() if v is not None})
    node_names = {n: dbc_name(names.get(n, f"node{n}")) for n in ods}
    receivers: dict[int, list[str]] = {}
    for node, od in pmap.ods.items():  # who consumes each COB-ID (its RPDOs)
        for cob, pdef in PdoMap(ods={node: od}).table.items():
            if pdef.direction == "RPDO" and pdef.valid:
                receivers.setdefault(cob, []).append(node_names[node])
    nodes_line = "BU_: " + " ".join(node_names[n] for n in sorted(node_names))
    lines = ['VERSION ""', "", "NS_ :", "", "BS_:", "", nodes_line, ""]
    valtypes, comments, tables = [], [], []
    materials = list(load_render_table())
    for cob, pdef in sorted(pmap.table.items()):
        if pdef.direction != "TPDO" or not pdef.valid or pdef.cob_id > 0x7FF:
            continue
        sender = node_names.get(pdef.node, f"node{pdef.node}")
        size = (pdef.length_bits + 7) // 8
        lines.append(f"BO_ {cob} {sender}_{pdef.label}: {size} {sender}")
        who = _quote(names.get(pdef.node, ""))
        comments.append(f'CM_ BO_ {cob} "{pdef.label} of node {pdef.node} ({who})";')
        to = ",".join(sorted(set(receivers.get(cob, [])) - {sender})) or "Vector__XXX"
        offset = 0
        for e in pdef.entries:
            start, offset = offset, offset + e.bits
            if e.var is None:
                continue  # a dummy mapping: bits skipped
            kind = e.var.data_type
            signed = "-" if kind in dt.SIGNED_TYPES or kind in dt.FLOAT_TYPES else "+"
            sig = dbc_name(e.name)
            lines.append(f' SG_ {sig} : {start}|{e.bits}@1{signed} (1,0) [0|0] "{_quote(e.unit)}" {to}')
            if kind in dt.FLOAT_TYPES:
                valtypes.append(f"SIG_VALTYPE_ {cob} {sig} : {1 if kind == dt.REAL32 else 2};")
            comments.append(f'CM_ SG_ {cob} {sig} "0x{e.index:04X}:{e.subindex:02X} {_quote(e.name)}";')
            if (e.index, e.name) in MATERIAL_CODE_OBJECTS:
                vals = [
                    (0, "none"),
                    *((k + 1, m) for k, m in enumerate(materials)),
                    (ABSTAIN_CODE, "unknown"),
                ]
                tables.append(f"VAL_ {cob} {sig} " + " ".join(f'{v} "{_quote(t)}"' for v, t in vals) + " ;")
        lines.append("")
    return "\n".join(lines + comments + [""] + valtypes + [""] + tables) + "\n"
