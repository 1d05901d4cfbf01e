"""The object dictionary of both nodes, written once, rendered to CiA 306 EDS text.

``bus_config/master.eds`` and ``bus_config/slave.eds`` are generated from the tables below (and
checked in: they are the contract other tools read). Regenerate after editing this file::

    python -m telethermo.bus_config.edsgen          # rewrites master.eds and slave.eds (atomically) and,
                                                    # in a checkout, docs/parameters.md and the table of
                                                    # docs/canopen.md
    python -m telethermo.bus_config.edsgen --check  # exit 1 if one of them differs

Naming convention (the operator CLI ``get``/``set`` and the bus monitor rely on it):

- Communication objects (0x1000..0x1FFF) keep their CiA 301 names.
- Manufacturer objects (0x2000..) have snake_case names that end in their unit (telethermo/units.py):
  ``_C`` °C, ``_W`` W, ``_A`` A, ``_N`` N, ``_s`` s, ``_C_per_s`` °C/s, ``_A_per_C`` A/°C,
  ``_A_per_C_s`` A/(°C·s), ``_A_per_W`` A/W, ``_C_per_W`` °C/W; no suffix = dimensionless
  (count, code, flag, model order). The same unit is in the non-standard ``Unit=`` key (ASCII:
  ``degC``, ``W``, ...), which canopen reads into ``ODVariable.unit``.
- Every writable manufacturer object has ``LowLimit``/``HighLimit``. REAL32 limits are written as
  decimals (canopen's parser drops them; telethermo.device.eds_info re-reads them).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from telethermo.atomic import write_text_atomic
from telethermo.bus_config import path as _path
from telethermo.bus_config import partable
from telethermo.bus_config.od_communication import (  # CONTACT_PDO_BASE, IDENT_PDO_BASE: read from here too
    CONTACT_PDO_BASE as CONTACT_PDO_BASE,
    IDENT_PDO_BASE as IDENT_PDO_BASE,
    NODE_IDS,
    communication_objects,
)
from telethermo.bus_config.od_manufacturer import manufacturer_objects
from telethermo.bus_config.od_types import (  # noqa: F401 (UNIT_TEXT: the tests read it here too)
    BOOLEAN,
    INTEGER16,
    REAL32,
    REAL64,
    UNIT_TEXT,
    UNSIGNED8,
    UNSIGNED16,
    UNSIGNED32,
    VISIBLE_STRING,
    Obj,
    Var,
)

# CiA 306 [FileInfo] dates (mm-dd-yyyy, hh:mm(AM|PM)): of the object dictionary's last change, set by hand
# (the files are generated, so they must not change with the clock)
EDS_DATE, EDS_TIME = "11-23-2026", "10:00PM"


def _check_value(section: str, text: str) -> None:
    """A value every EDS reader takes: no ';' (an inline comment for canopen's parser), no line break,
    no '=' (canopen-monitor splits every line on '=' and crashes on a second one)."""
    if any(c in text for c in ";=\n"):
        raise ValueError(f"[{section}]: ';', '=' or a line break in {text!r} would break EDS readers")


def _var_lines(section: str, var: Var) -> list[str]:
    for text in (var.name, var.description, var.default, var.unit, var.low or "", var.high or ""):
        _check_value(section, text)
    lines = [
        f"[{section}]",
        f"ParameterName={var.name}",
        "ObjectType=0x7",
        f"DataType=0x{var.data_type:04X}",
        f"AccessType={var.access}",
        f"DefaultValue={var.default}",
        f"PDOMapping={int(var.pdo)}",
    ]
    if var.low is not None:
        lines.append(f"LowLimit={var.low}")
    if var.high is not None:
        lines.append(f"HighLimit={var.high}")
    if var.unit:
        lines.append(f"Unit={var.unit}")
    if var.description:
        lines.append(f"Description={var.description}")
    return lines + [""]


def eds_header(
    file_name: str,
    description: str,
    product_name: str,
    product_number: int,
    order_code: str,
    n_rx_tx: tuple[int, int],
    comments: list[str],
) -> list[str]:
    """An EDS file's [FileInfo], [DeviceInfo] (CiA 306: 125..1000 kbit/s, no LSS), [DummyUsage] and [Comments]
    sections, each ending in a blank line."""
    n_rx, n_tx = n_rx_tx
    return [
        "[FileInfo]",
        f"FileName={file_name}",
        "FileVersion=1",
        "FileRevision=0",
        "EDSVersion=4.0",
        f"Description={description}",
        f"CreationTime={EDS_TIME}",
        f"CreationDate={EDS_DATE}",
        "CreatedBy=telethermo",
        f"ModificationTime={EDS_TIME}",
        f"ModificationDate={EDS_DATE}",
        "ModifiedBy=telethermo",
        "",
        "[DeviceInfo]",
        "VendorName=telethermo",
        "VendorNumber=0x00000000",
        f"ProductName={product_name}",
        f"ProductNumber=0x{product_number:08X}",
        "RevisionNumber=0x00010000",
        f"OrderCode={order_code}",
        *[f"BaudRate_{r}={int(r in (125, 250, 500, 1000))}" for r in (10, 20, 50, 125, 250, 500, 800, 1000)],
        "SimpleBootUpMaster=0",
        "SimpleBootUpSlave=1",
        "Granularity=8",
        "DynamicChannelsSupported=0",
        "GroupMessaging=0",
        f"NrOfRXPDO={n_rx}",
        f"NrOfTXPDO={n_tx}",
        "LSS_Supported=0",
        "",
        "[DummyUsage]",
        *[f"Dummy{i:04d}=0" for i in range(1, 8)],
        "",
        "[Comments]",
        f"Lines={len(comments)}",
        *[f"Line{i}={c}" for i, c in enumerate(comments, 1)],
        "",
    ]


def pdo_counts(comm: list[Obj]) -> tuple[int, int]:
    """The numbers of RPDOs and TPDOs among the communication objects ``comm`` (their 0x14xx, 0x18xx)."""
    n_rx = sum(1 for o in comm if 0x1400 <= o.index <= 0x15FF)
    n_tx = sum(1 for o in comm if 0x1800 <= o.index <= 0x19FF)
    return n_rx, n_tx


def render_eds(
    label: str,
    header: list[str],
    comm: list[Obj],
    manu: list[Obj],
    var_lines: Callable[[str, Var], list[str]] = _var_lines,
) -> str:
    """An EDS file's text: ``header`` (:func:`eds_header`), the object lists (mandatory: 0x1000, 0x1001,
    0x1018) and a section per object and sub-entry (``var_lines`` writes a VAR's); ``label`` names the file
    in the error on a value EDS readers would break on."""
    mandatory = [o for o in comm if o.index in (0x1000, 0x1001, 0x1018)]
    optional = [o for o in comm if o not in mandatory]
    out = list(header)
    for title, objs in (
        ("MandatoryObjects", mandatory),
        ("OptionalObjects", optional),
        ("ManufacturerObjects", manu),
    ):
        out += [f"[{title}]", f"SupportedObjects={len(objs)}"]
        out += [f"{i}=0x{o.index:04X}" for i, o in enumerate(objs, 1)] + [""]
    for o in comm + manu:
        if o.var is not None:
            out += var_lines(f"{o.index:04X}", o.var)
            continue
        out += [
            f"[{o.index:04X}]",
            f"ParameterName={o.name}",
            f"ObjectType=0x{o.object_type:X}",
            f"SubNumber=0x{len(o.subs):X}",
            "",
        ]
        for sub, var in o.subs.items():
            out += var_lines(f"{o.index:04X}sub{sub:X}", var)
    for line in out:  # every value of every section, the file's own keys included
        if "=" in line:
            _check_value(label, line.split("=", 1)[1])
    return "\n".join(out)


def render(role: str) -> str:
    """The EDS text of ``role`` ("master" or "slave")."""
    if role not in NODE_IDS:
        raise ValueError(f"role must be one of {sorted(NODE_IDS)}, got {role!r}")
    comm, manu = communication_objects(role), manufacturer_objects(role)
    header = eds_header(
        f"{role}.eds",
        f"telethermo {role} node (bilateral thermal telepresence), generated by bus_config/edsgen.py",
        f"telethermo {role}",
        NODE_IDS[role],
        f"telethermo-{role}",
        pdo_counts(comm),
        [
            "Manufacturer object names end in their unit (_C degC, _W, _A, _s, ...).",
            "REAL32 LowLimit/HighLimit are decimals, SDO writes outside them abort 0x06090030/31/32.",
        ],
    )
    return render_eds(role, header, comm, manu)


def markdown_table(role: str = "master") -> str:
    """The object dictionary as a Markdown table (for docs/canopen.md)."""
    types = {
        BOOLEAN: "BOOLEAN",
        UNSIGNED8: "U8",
        UNSIGNED16: "U16",
        UNSIGNED32: "U32",
        REAL32: "REAL32",
        REAL64: "REAL64",
        VISIBLE_STRING: "STRING",
        INTEGER16: "I16",
    }
    rows = [
        "| index | sub | name | type | access | default | range | unit | PDO |",
        "|---|---|---|---|---|---|---|---|---|",
    ]

    def row(index, sub, var):
        rng = f"{var.low} .. {var.high}" if var.low is not None else ""
        rows.append(
            f"| 0x{index:04X} | {sub} | {var.name} | {types.get(var.data_type, hex(var.data_type))} | "
            f"{var.access} | {var.default} | {rng} | {var.unit} | {'yes' if var.pdo else ''} |"
        )

    for o in communication_objects(role) + manufacturer_objects(role):
        if o.var is not None:
            row(o.index, 0, o.var)
        elif o.index in (0x2310, 0x2311):
            first, last = o.subs[1], o.subs[len(o.subs) - 1]
            rows.append(
                f"| 0x{o.index:04X} | 1..{len(o.subs) - 1} | {o.name}: {first.name}..{last.name} | "
                f"{types[first.data_type]} | "
                f"{first.access} | {first.default} | {first.low} .. {first.high} | | |"
            )
        else:
            for sub, var in o.subs.items():
                row(o.index, sub, var)
    return "\n".join(rows)


CANOPEN_DOC = partable.DOC.with_name("canopen.md")
TABLE_HEAD = "| index | sub | name | type | access | default | range | unit | PDO |"


def docs() -> dict[Path, str]:
    """The generated docs pages of a checkout (none when the docs are not there): path -> text."""
    if not CANOPEN_DOC.exists():
        return {}
    lines = CANOPEN_DOC.read_text(encoding="utf-8").split("\n")
    start = lines.index(TABLE_HEAD)
    end = next((i for i in range(start, len(lines)) if not lines[i].startswith("|")), len(lines))
    canopen_doc = "\n".join(lines[:start] + [markdown_table("master")] + lines[end:])
    return {partable.DOC: partable.markdown(), CANOPEN_DOC: canopen_doc}


def main(argv: list[str] | None = None) -> int:

    parser = argparse.ArgumentParser(description="Generate bus_config/master.eds and slave.eds.")
    parser.add_argument("--check", action="store_true", help="only compare; exit 1 if a file differs")
    parser.add_argument("--table", metavar="ROLE", help="print the object dictionary of ROLE as Markdown")
    args = parser.parse_args(argv)
    if args.table:
        print(markdown_table(args.table))
        return 0
    stale = []
    outputs = {Path(_path(f"{role}.eds")): render(role) for role in NODE_IDS}
    for target, text in [*outputs.items(), *docs().items()]:
        if args.check:
            if not target.exists() or target.read_text(encoding="utf-8") != text:
                stale.append(str(target))
        else:
            write_text_atomic(target, text)
    if stale:
        print("stale (run python -m telethermo.bus_config.edsgen): " + ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
