"""Errors of the simulator package."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from telethermo.inputfile import ABSENT, InputFileError


class SceneError(InputFileError):
    """A malformed scene (or data) file: the message names the file, the field and what was expected
    (``file: field 'F': expected E[, got G]``; an error of the whole file or of a line: ``file: problem``)."""

    def __init__(self, file: str | Path, field: str, expected: str, got: object = None) -> None:
        msg = f"{file}: field '{field}': expected {expected}"
        if got is not None:
            msg += f", got {got!r}"
        super().__init__(msg, file, field)
        self.expected = expected

    @classmethod
    def at(cls, file: str | Path, field: str, expected: str, got: Any = ABSENT) -> SceneError:
        return cls(file, field, expected, None if got is ABSENT else got)

    @classmethod
    def whole(cls, file: str | Path, problem: str, field: str | None = None) -> SceneError:
        err = cls.__new__(cls)
        InputFileError.__init__(err, f"{file}: {problem}", file, field or "<file>")
        err.expected = problem
        return err
