"""The gains file the nodes load (``--gains FILE``): format, validation, atomic write.

    {"format": "telethermo.gains/1", "period_s": 0.01,
     "master": {"kp_A_per_C": 1.66, ...}, "slave": {...}, ...}        (docs/tuning.md)

``default_params(role, **load_gains(path)[role])`` gives the tuned parameters. ``"apply"``
(:func:`apply_marks`) says which keys a running node takes by SDO and which need a restart. Other keys (the
tuner's objective and search, see :func:`telethermo.tuning.document.gains_document`) are kept for
the record and ignored here. The file is read by :func:`telethermo.inputfile.load_json`: every error is one
line naming the file, the field (``master.kp_A_per_C``) and what was expected (InputFileError, a
ValueError).
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any, cast

from telethermo.atomic import write_json_atomic
from telethermo.control.gain_fields import GAIN_FIELDS, RESTART_GAIN_FIELDS, SDO_GAIN_FIELDS
from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.inputfile import InputFileError, Section, load_json

GAINS_FORMAT = "telethermo.gains/1"


def apply_marks() -> dict[str, Any]:
    """The gains file's ``"apply"`` entry: which of its keys ``telethermo apply-gains`` (or ``set``) can write
    to a running node, which need a node start with ``--gains FILE``, and the mode they are gains of."""
    return {"mode": "telepresence", "sdo": list(SDO_GAIN_FIELDS), "restart": list(RESTART_GAIN_FIELDS)}


GAINS_FILE = f"a gains file ({GAINS_FORMAT}, written by `telethermo tune --out`)"


def read_gains(doc: Section) -> dict[Role, dict[str, float]]:
    """The gains of a gains document read through ``doc`` -> {Role: {CoreParams field: value}} (the overrides
    of default_params); an error names the file, the field (``master.kp_A_per_C``) and what was expected."""
    doc.str("format", choices=(GAINS_FORMAT,))
    out: dict[Role, dict[str, float]] = {}
    for role in (Role.MASTER, Role.SLAVE):
        r = doc.table(role.value, set(GAIN_FIELDS), expected="an object of gains")
        vals = {k: cast(float, r.float(k)) for k in r.raw}
        try:  # CoreParams validates the ranges: "CoreParams.<field>: expected ..."
            default_params(role, **cast(dict[str, Any], vals))
        except ValueError as exc:
            m = re.fullmatch(r"CoreParams\.(\w+): (.*)", str(exc))
            if m is None or m.group(1) not in vals:
                raise doc.error.whole(doc.file, f"{role.value}: {exc}", role.value) from None
            name = r.name(m.group(1))
            raise doc.error(f"{doc.file}: {name}: {m.group(2)}", doc.file, name) from None
        out[role] = vals
    return out


def parse_gains(doc: Any, where: str = "gains") -> dict[Role, dict[str, float]]:
    """Validate a gains document (the parsed JSON; ``where`` names it in errors), see :func:`read_gains`."""
    if not isinstance(doc, dict):
        raise InputFileError.whole(where, f"top level: expected a JSON object, got {type(doc).__name__}")
    return read_gains(Section(where, "", doc, dotted=True))


def load_gains(path: str | os.PathLike[str]) -> dict[Role, dict[str, float]]:
    """Read a gains file: ``default_params(role, **load_gains(path)[role])`` gives the tuned parameters."""
    return read_gains(load_json(path, GAINS_FILE))


def write_gains(path: str | os.PathLike[str], doc: dict[str, Any]) -> Path:
    """Write a gains document atomically (validated first)."""
    parse_gains(doc, str(path))
    return write_json_atomic(path, doc)
