"""Errors of the simulator package."""

from __future__ import annotations


class SceneError(ValueError):
    """A malformed scene (or data) file: the message names the file, the field and what was expected."""

    def __init__(self, file: str, field: str, expected: str, got: object = None) -> None:
        self.file, self.field, self.expected = str(file), field, expected
        msg = f"{file}: field '{field}': expected {expected}"
        if got is not None:
            msg += f", got {got!r}"
        super().__init__(msg)
