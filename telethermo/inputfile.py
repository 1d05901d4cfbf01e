"""One reader for every TOML and JSON input file: load it, and read its tables (objects) field by field,
every error one line naming the file, the field (or line) and what was expected (issue 26 item 5)::

    bus_config/network.toml: [heartbeat] consumer_ms: expected an integer in [0, 65535] ms, got -1
    RIG.toml: signals.T_sensor_C.subindex: expected an integer in [0, 255], got 300
    scene.toml: line 3: not valid TOML (Expected '=' after a key in a key/value pair (at line 3, column 5))
    gains.json: master.kp_A_per_C: expected a finite number, got 'fast'
    node1.json: line 4 column 1: not valid JSON (Expecting ',' delimiter)

A field is named ``[table] key`` (``key`` at the top level) or, for a reader made with ``dotted=True``, by
its dotted path (``table.key``), as the fields of a JSON file always are. Every error is an
:class:`InputFileError`; a caller passes its own subclass (``error=NetworkConfigError``) so that its CLI,
which turns that type into ``prog: error: <line>`` and exit status 2 without a traceback, keeps doing so.
"""

from __future__ import annotations

import builtins
import json
import math
import os
import re
import tomllib
from pathlib import Path
from typing import Any, TypeVar


class _Absent:
    def __repr__(self) -> str:
        return "ABSENT"


#: no value: a required field (as a default) or an error without a "got" part (as ``got``)
ABSENT: Any = _Absent()
E = TypeVar("E", bound="InputFileError")


class InputFileError(ValueError):
    """A bad input file: one line naming the file, the field (or line) and what was expected."""

    def __init__(self, message: str, file: str | Path | None = None, field: str | None = None):
        super().__init__(message.replace("\n", " "))
        self.file, self.field = (None if file is None else str(file)), field

    @classmethod
    def at(cls: type[E], file: str | Path, field: str, expected: str, got: Any = ABSENT) -> E:
        """``file: field: expected <expected>[, got <got!r>]``."""
        got_text = "" if got is ABSENT else f", got {got!r}"
        return cls(f"{file}: {field}: expected {expected}{got_text}", file, field)

    @classmethod
    def whole(cls: type[E], file: str | Path, problem: str, field: str | None = None) -> E:
        """An error of the whole file, or of a line of it (``field``: "line 3"): ``file: problem``."""
        return cls(f"{file}: {problem}", file, field)


def decode_line(exc: tomllib.TOMLDecodeError, text: str) -> int:
    """The line a TOML syntax error is on (Python 3.11's error has it in its text only; "at end of
    document": the last line)."""
    m = re.search(r"at line (\d+)", str(exc))
    return int(m.group(1)) if m else text.count("\n") + 1


def parse_toml(text: str, source: str | Path, error: type[InputFileError] = InputFileError) -> dict[str, Any]:
    """The TOML document of ``text`` (``source`` names it in errors, with the line of a syntax error)."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        line = decode_line(exc, text)
        raise error.whole(source, f"line {line}: not valid TOML ({exc})", f"line {line}") from None


def _read_text(path: str | os.PathLike[str], error: type[InputFileError], what: str) -> tuple[Path, str]:
    """The UTF-8 text of ``path``; a missing, unreadable or non-UTF-8 file raises ``error`` with one line."""
    file = Path(path)
    try:
        data = file.read_bytes()
    except FileNotFoundError:
        raise error.whole(file, f"no such file (expected {what})") from None
    except IsADirectoryError:
        raise error.whole(file, f"a folder, not a file (expected {what})") from None
    except OSError as exc:
        raise error.whole(file, f"cannot read ({exc.strerror or exc})") from None
    try:
        return file, data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        bad = data[exc.start]
        raise error.whole(file, f"line {line}: not UTF-8 text (byte 0x{bad:02X})", f"line {line}") from None


def load_toml(
    path: str | os.PathLike[str], error: type[InputFileError] = InputFileError, what: str = "a TOML file"
) -> dict[str, Any]:
    """Read and parse the TOML file ``path``: a missing, unreadable, non-UTF-8 or malformed file raises
    ``error`` with one line (``what`` says what the file should have been)."""
    file, text = _read_text(path, error, what)
    return parse_toml(text, file, error)


_JSON_KINDS = {list: "an array", str: "a string", bool: "true or false", type(None): "null"}


def parse_json(text: str, file: str | Path, error: type[InputFileError] = InputFileError) -> Section:
    """The top-level object of the JSON document ``text`` as a :class:`Section` whose fields are named by
    their dotted path (``master.kp_A_per_C``); ``file`` names the document in errors. A syntax error names
    its line and column; a top level that is not an object is one line naming the file.

    JSON numbers read as Python ints and floats (``true`` is not a number, as in TOML); the non-standard
    ``NaN`` and ``Infinity`` that Python's reader takes read as floats that :meth:`Section.float` refuses
    as not finite."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        where = f"line {exc.lineno}"
        raise error.whole(file, f"{where} column {exc.colno}: not valid JSON ({exc.msg})", where) from None
    except (ValueError, RecursionError) as exc:  # an integer of > 4300 digits; nesting deeper than ~1000
        raise error.whole(file, f"not valid JSON ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, dict):
        kind = _JSON_KINDS.get(type(doc), "a number")
        raise error.whole(file, f"top level: expected a JSON object {{...}}, got {kind}", "top level")
    return Section(file, "", doc, error=error, dotted=True)


def load_json(
    path: str | os.PathLike[str], what: str = "a JSON file", error: type[InputFileError] = InputFileError
) -> Section:
    """Read and parse the JSON file ``path`` (see :func:`parse_json`): a missing, unreadable, non-UTF-8 or
    malformed file raises ``error`` with one line (``what`` says what the file should have been)."""
    file, text = _read_text(path, error, what)
    return parse_json(text, file, error)


def _g(v: Any) -> str:
    """A bound as a person writes it: 10000, 0.001, 1000000 (not 1e+06), 1e-05."""
    if isinstance(v, int) or (v.is_integer() and abs(v) < 1e16):
        return str(int(v))
    return f"{v:g}"


def _finite(v: Any) -> bool:
    """True for a number a float can hold (TOML integers have no size limit)."""
    try:
        return math.isfinite(v)
    except OverflowError:
        return False


def _range(lo: Any, hi: Any, lo_open: bool = False) -> str:
    """ " in [lo, hi]" ("(lo, hi]" when ``lo_open``), " >= lo", " <= hi" or ""."""
    if lo is not None and hi is not None:
        return f" in {'(' if lo_open else '['}{_g(lo)}, {_g(hi)}]"
    if lo is not None:
        return f" {'>' if lo_open else '>='} {_g(lo)}"
    return "" if hi is None else f" <= {_g(hi)}"


class Section:
    """One TOML table (or JSON object) of ``file`` read field by field, each error naming the field.

    ``path`` is the table's dotted name ("" for the top level); ``allowed`` (when given) are its only
    keys. A ``default`` of :data:`ABSENT` makes a field required."""

    def __init__(
        self,
        file: str | Path,
        path: builtins.str,
        table: Any,
        allowed: set[builtins.str] | None = None,
        *,
        error: type[InputFileError] = InputFileError,
        dotted: builtins.bool = False,
        expected: builtins.str = "a table",
    ):
        self.file, self.path, self.error, self.dotted = file, path, error, dotted
        if not isinstance(table, dict):
            raise self.error.at(file, self.name(), expected, table)
        self.raw: dict[builtins.str, Any] = table
        if allowed is not None:
            self.check_keys(allowed)

    def name(self, key: builtins.str | None = None) -> builtins.str:
        """The field ``key`` as errors name it (the table itself without a key)."""
        if self.dotted:
            return ".".join(p for p in (self.path, key) if p) or "top level"
        table = f"[{self.path or 'top level'}]"
        if key is None:
            return table
        return f"{table} {key}" if self.path else key

    def fail(self, key: builtins.str | None, expected: builtins.str, got: Any = ABSENT) -> InputFileError:
        """The error of field ``key`` (None: of the table): raise it."""
        return self.error.at(self.file, self.name(key), expected, got)

    def check_keys(self, allowed: set[builtins.str]) -> None:
        """Refuse a key not in ``allowed`` (naming it and the allowed ones)."""
        for key in self.raw:
            if key not in allowed:
                raise self.fail(key, f"one of {', '.join(sorted(allowed))} (an unknown key)")

    def has(self, key: builtins.str) -> builtins.bool:
        return key in self.raw

    def get(self, key: builtins.str, default: Any = ABSENT, expected: builtins.str = "a value") -> Any:
        """The raw value of ``key``; a missing required one is an error saying what it should be."""
        if key in self.raw:
            return self.raw[key]
        if default is ABSENT:
            raise self.fail(key, f"{expected} (missing)")
        return default

    def str(
        self,
        key: builtins.str,
        default: Any = ABSENT,
        choices: tuple[builtins.str, ...] | None = None,
        nonempty: builtins.bool = True,
    ) -> Any:
        """A string (non-empty unless told; one of ``choices`` when given); a default is returned as is."""
        expected = (
            f"one of {', '.join(choices)}" if choices else "a non-empty string" if nonempty else "a string"
        )
        v = self.get(key, default, expected)
        if key not in self.raw:
            return v
        if not isinstance(v, builtins.str) or (nonempty and not v) or (choices and v not in choices):
            raise self.fail(key, expected, v)
        return v

    def int(
        self,
        key: builtins.str,
        default: Any = ABSENT,
        lo: builtins.int | None = None,
        hi: builtins.int | None = None,
        unit: builtins.str = "",
        expected: builtins.str | None = None,
    ) -> Any:
        """An integer (not a bool) in [lo, hi]; ``unit`` (" ms") and ``expected`` refine the message."""
        expected = expected or f"an integer{_range(lo, hi)}{unit}"
        v = self.get(key, default, expected)
        if key not in self.raw:
            return v
        if (
            isinstance(v, builtins.bool)
            or not isinstance(v, builtins.int)
            or (lo is not None and v < lo)
            or (hi is not None and v > hi)
        ):
            raise self.fail(key, expected, v)
        return v

    def float(
        self,
        key: builtins.str,
        default: Any = ABSENT,
        lo: builtins.float | None = None,
        hi: builtins.float | None = None,
        unit: builtins.str = "",
        *,
        positive: builtins.bool = False,
        nonzero: builtins.bool = False,
        lo_open: builtins.bool = False,
        expected: builtins.str | None = None,
    ) -> Any:
        """A finite number (integers accepted, returned as float) in [lo, hi], > 0 when ``positive``,
        not 0 when ``nonzero``; ``unit`` (" s") and ``expected`` refine the message."""
        if expected is None:
            bounded = lo is not None or hi is not None
            kind = "a number > 0" if positive else "a non-zero number" if nonzero else None
            expected = (
                (kind or ("a number" if bounded else "a finite number")) + _range(lo, hi, lo_open) + unit
            )
        v = self.get(key, default, expected)
        if key not in self.raw:
            return v
        ok = not isinstance(v, builtins.bool) and isinstance(v, (builtins.int, builtins.float))
        ok = ok and _finite(v) and not (positive and v <= 0) and not (nonzero and v == 0)
        ok = ok and (lo is None or v > lo or (v == lo and not lo_open)) and (hi is None or v <= hi)
        if not ok:
            raise self.fail(key, expected, v)
        return builtins.float(v)

    def bool(self, key: builtins.str, default: Any = ABSENT) -> Any:
        """true or false."""
        v = self.get(key, default, "true or false")
        if key in self.raw and not isinstance(v, builtins.bool):
            raise self.fail(key, "true or false", v)
        return v

    def list(self, key: builtins.str, default: Any = ABSENT, expected: builtins.str = "a list") -> Any:
        """A list (items are the caller's to check, with :meth:`fail`)."""
        v = self.get(key, default, expected)
        if key in self.raw and not isinstance(v, builtins.list):
            raise self.fail(key, expected, v)
        return v

    def table(
        self,
        key: builtins.str,
        allowed: set[builtins.str] | None = None,
        default: Any = ABSENT,
        expected: builtins.str = "a table",
    ) -> Section:
        """The sub-table ``key`` as a Section (a missing optional one reads as ``default``, e.g. ``{}``)."""
        path = f"{self.path}.{key}" if self.path else key
        if key not in self.raw and default is ABSENT:
            raise self.fail(key, f"{expected} (missing)")
        return Section(
            self.file,
            path,
            self.raw.get(key, default),
            allowed,
            error=self.error,
            dotted=self.dotted,
            expected=expected,
        )
