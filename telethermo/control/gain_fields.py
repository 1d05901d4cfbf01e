"""The gains a gains file holds and which of them a running node takes by SDO (light imports only: the CLI
commands ``get``/``set`` read it without numpy).

The nodes' object dictionary holds the per-mode gains of the parameter table (``bus_config/partable.py``:
kp, ki, kQ, 0x2200..0x2202); the others (the flux loop's kpQ, kiQ) have no object and take a node start
with ``--gains FILE``. :mod:`telethermo.control.gainsfile` writes the
split into each gains file (its ``"apply"`` entry); ``telethermo apply-gains`` reads it.
"""

from __future__ import annotations

from telethermo.bus_config.partable import GAINS as PER_MODE, PARAMS

#: the gains a gains file may set (CoreParams field names)
GAIN_FIELDS = ("kp_A_per_C", "ki_A_per_C_s", "kQ_A_per_W", "kpQ_A_per_W", "kiQ_A_per_W_s")
#: the gains a running node takes by SDO (the per-mode rows of the parameter table: 0x2200..0x2202)
SDO_GAIN_FIELDS: tuple[str, ...] = tuple(p.field[0] for p in PARAMS if p.scope == PER_MODE)
#: the gains without an object: a node start with ``--gains FILE``
RESTART_GAIN_FIELDS = tuple(k for k in GAIN_FIELDS if k not in SDO_GAIN_FIELDS)
