"""What can go wrong talking to a remote node, in two kinds the CLI maps to its exit codes.

:class:`UserError`: the operator can fix it (a bad node name, parameter name or value, a bad EDS file):
one line, exit 2. :class:`Failure`: the node or the bus did it (a node that does not answer, an SDO
abort): one line, exit 1. :class:`Refused` is a Failure with the node's SDO abort code.
"""

from __future__ import annotations

from telethermo.cia301 import sdo_abort_text


class UserError(Exception):
    """An error the user can fix (bad argument, bad file, unknown parameter): one line, exit 2."""


class Failure(Exception):
    """A runtime failure (node silent, SDO refused): one line on stderr, exit 1."""


class Refused(Failure):
    """A node refused an SDO write: ``code`` is its abort code."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.code = code


def abort_text(code: int) -> str:
    """``SDO abort 0x........: <CiA 301 meaning>``."""
    return f"SDO abort 0x{code:08X}: {sdo_abort_text(code)}"
