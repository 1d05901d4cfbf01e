"""TEM model files: one documented JSON format, written atomically, validated on load.

Format (``format`` = "telethermo-tem-model", ``format_version`` = 1; see docs/identification.md)::

    {
      "format": "telethermo-tem-model", "format_version": 1,
      "units": {"temperature": "degC", "current": "A", "heat_flux": "W", "time": "s"},
      "temperature": {                       # NARMA model, guiatni eq. 10, deviation form
        "kind": "narma", "orders": {"n": 3, "m": 3, "p": 3, "q": 3},
        "period_s": 0.01, "T_ref_C": 25.0,
        "current_range_A": [-1.0, 1.0], "T_range_C": [20.1, 31.7],
        "columns": ["T1", "T1*I1^1", ...],   # regressor names, θ order (checked against the orders)
        "theta": [...],                      # d = n(p+1) + m(q+1) numbers
        "metrics": {...}, "data_sha256": "<64 hex>"
      },
      "flux": null | {"kind": "arma", "period_s": 0.01, "T_ref_C": 25.0, "c": [n], "d": [m+1],
                      "e": [m or 0], "g": [m or 0], "h": [m or 0],  # current terms (flux.py)
                      "metrics": {...}},
      "capacity": null | {"kind": "capacity-eq13", "theta": [5 numbers], "current_range_A": [lo, hi],
                          "metrics": {...}},
      "meta": {...}                          # free-form provenance: rig, scene, seed, date, ...
    }

Loading validates every field (type, length, finiteness, ranges, the orders against θ's length and the
column names, flux period = temperature period) and the stability of the temperature model; any
failure raises :class:`ModelFileError` naming the file, the field and what was expected.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from telethermo.atomic import write_json_atomic
from telethermo.ident.capacity import CapacityModel
from telethermo.ident.flux import FluxArma
from telethermo.ident.narma import MAX_ORDER, NarmaModel, NarmaOrders
from telethermo.ident.stability import check_stability as _check
from telethermo.inputfile import ABSENT, InputFileError, Section, load_json
from telethermo.units import MODEL_KINDS, base_unit

FORMAT = "telethermo-tem-model"
FORMAT_VERSION = 1
#: the unit of each quantity in a model file (kind -> unit name of the one unit table)
UNITS = {kind: base_unit(kind) for kind in MODEL_KINDS}


class ModelFileError(InputFileError):
    """A model file is missing, malformed, inconsistent or holds an unstable model.

    Attributes: ``path`` (the file), ``field`` (dotted JSON path, '' for the whole file, "line 3" for a
    syntax error), ``expected`` (what was expected), ``got`` (what was found, short).
    """

    def __init__(self, path: str | os.PathLike[str], field: str, expected: str, got: str = "") -> None:
        where = f"field '{field}': " if field else ""
        tail = f", got {got}" if got else ""
        super().__init__(f"model file {path}: {where}expected {expected}{tail}", str(path), field)
        self.path, self.field, self.expected, self.got = str(path), field, expected, got

    @classmethod
    def at(cls, file: str | Path, field: str, expected: str, got: Any = ABSENT) -> ModelFileError:
        """A field's error (for :class:`~telethermo.inputfile.Section`), ``got`` cut to 80 characters."""
        text = "" if got is ABSENT else got if isinstance(got, str) else repr(got)
        return cls(file, field, expected, text[:80])

    @classmethod
    def whole(cls, file: str | Path, problem: str, field: str | None = None) -> ModelFileError:
        """An error of the whole file (missing, not UTF-8, not JSON): ``model file F: problem``."""
        err = cls.__new__(cls)
        InputFileError.__init__(err, f"model file {file}: {problem}", str(file), field or "")
        err.path, err.field, err.expected, err.got = str(file), field or "", problem, ""
        return err


@dataclass(frozen=True)
class TemModel:
    """Everything identified on one rig: the temperature model (required), the heat-flux model and the
    capacity model (optional), and free-form provenance ``meta``."""

    temperature: NarmaModel
    flux: FluxArma | None = None
    capacity: CapacityModel | None = None
    meta: dict[str, Any] = field(default_factory=dict)


def default_model_path() -> Path:
    """The shipped model of the default simulated rig (``sim.free_pad_rig()``):
    telethermo/data/models/sim_tem.json."""
    return Path(__file__).resolve().parent.parent / "data" / "models" / "sim_tem.json"


def _clean(obj: Any) -> Any:
    """JSON-safe copy: numpy scalars/arrays to Python, non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [_clean(v) for v in (obj.tolist() if isinstance(obj, np.ndarray) else obj)]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


def model_to_dict(tem: TemModel) -> dict[str, Any]:
    """The JSON document of ``tem`` (see the module docstring)."""
    t = tem.temperature
    doc: dict[str, Any] = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "units": dict(UNITS),
        "temperature": {
            "kind": "narma",
            "orders": t.orders.as_dict(),
            "period_s": t.period_s,
            "T_ref_C": t.T_ref_C,
            "current_range_A": list(t.current_range_A),
            "T_range_C": list(t.T_range_C),
            "columns": t.orders.column_names(),
            "theta": [float(v) for v in t.theta],
            "metrics": _clean(t.metrics),
            "data_sha256": t.data_sha256,
        },
        "flux": None,
        "capacity": None,
        "meta": _clean(tem.meta),
    }
    if tem.flux is not None:
        f = tem.flux
        doc["flux"] = {
            "kind": "arma",
            "period_s": f.period_s,
            "T_ref_C": f.T_ref_C,
            "c": [float(v) for v in f.c],
            "d": [float(v) for v in f.d],
            "e": [float(v) for v in f.e],
            "g": [float(v) for v in f.g],
            "h": [float(v) for v in f.h],
            "metrics": _clean(f.metrics),
        }
    if tem.capacity is not None:
        c = tem.capacity
        doc["capacity"] = {
            "kind": "capacity-eq13",
            "theta": [float(v) for v in c.theta],
            "current_range_A": list(c.current_range_A),
            "metrics": _clean(c.metrics),
        }
    return doc


def save_model(path: str | os.PathLike[str], tem: TemModel) -> Path:
    """Write ``tem`` to ``path`` as JSON, atomically (a reader sees the old file or the new one)."""
    if not isinstance(tem, TemModel):
        raise TypeError(f"save_model needs a TemModel, got {type(tem).__name__}")
    return write_json_atomic(path, model_to_dict(tem))


MAX_CURRENT_A = 100.0
"""Largest |current| a model file may claim to cover, A (TEMs of this class run at a few A)."""


def _numbers(
    s: Section, key: str, *, length: int | None = None, min_len: int = 1, max_len: int = 10_000
) -> np.ndarray:
    """The list field ``key`` of finite numbers (``length`` of them, or ``min_len``..``max_len``)."""
    want = (
        f"a list of {length} finite numbers"
        if length is not None
        else f"a list of {min_len}..{max_len} finite numbers"
    )
    v = s.list(key, expected=want)
    if (length is not None and len(v) != length) or not (min_len <= len(v) <= max_len):
        raise s.fail(key, want, f"{len(v)} values")
    for i, x in enumerate(v):
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not _finite(x):
            raise s.fail(f"{key}[{i}]", "a finite number", x)
    return np.asarray(v, dtype=float)


def _finite(v: int | float) -> bool:
    """True for a number a float can hold (JSON integers have no size limit)."""
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


def _range(s: Section, key: str) -> tuple[float, float]:
    """The field ``key``: ``[min, max]``, two finite numbers with min <= max."""
    lo, hi = _numbers(s, key, length=2)
    if lo > hi:
        raise s.fail(key, "[min, max] with min <= max", [lo, hi])
    return float(lo), float(hi)


def _metrics(s: Section) -> dict[str, Any]:
    """The free-form ``metrics`` object ({} when absent or null)."""
    m = s.get("metrics", None)
    if m is not None and not isinstance(m, dict):
        raise s.fail("metrics", "an object", m)
    return m or {}


def _kind(s: Section, kind: str) -> None:
    if s.get("kind", None) != kind:
        raise s.fail("kind", f"'{kind}'", s.get("kind", "missing"))


def _optional(doc: Section, key: str) -> Section | None:
    """The object ``key`` of ``doc``, None when absent or null."""
    return None if doc.get(key, None) is None else doc.table(key, expected="an object")


def model_from_dict(
    doc: Any,
    *,
    path: str | os.PathLike[str] = "<dict>",
    check_stability: bool = True,
    expect_period_s: float | None = None,
) -> TemModel:
    """Validate a model document and build the :class:`TemModel` (errors: :class:`ModelFileError`)."""
    if not isinstance(doc, dict):
        raise ModelFileError(path, "", "a JSON object at the top level", type(doc).__name__)
    section = Section(str(path), "", doc, error=ModelFileError, dotted=True)
    return read_model(section, check_stability=check_stability, expect_period_s=expect_period_s)


def read_model(
    doc: Section, *, check_stability: bool = True, expect_period_s: float | None = None
) -> TemModel:
    """The :class:`TemModel` of a model document read through ``doc`` (errors: :class:`ModelFileError`
    naming the file, the dotted field and what was expected)."""
    if doc.get("format", None) != FORMAT:
        raise doc.fail("format", f"'{FORMAT}'", doc.get("format", "missing"))
    # a JSON true equals 1 in Python: read as an integer first
    expected = f"{FORMAT_VERSION} (the version this program reads)"
    doc.int("format_version", lo=FORMAT_VERSION, hi=FORMAT_VERSION, expected=expected)
    units = doc.get("units", UNITS)
    if units != UNITS:
        raise doc.fail("units", f"{UNITS}", units)
    temp = _temperature(doc.table("temperature", expected="an object"), check_stability, expect_period_s)
    flux = _optional(doc, "flux")
    cap = _optional(doc, "capacity")
    meta = doc.get("meta", {})
    if not isinstance(meta, dict):
        raise doc.fail("meta", "an object", meta)
    return TemModel(
        temperature=temp,
        flux=None if flux is None else _flux(flux, temp.period_s),
        capacity=None if cap is None else _capacity(cap),
        meta=meta,
    )


def _temperature(t: Section, check_stability: bool, expect_period_s: float | None) -> NarmaModel:
    """The document's ``temperature`` (NARMA) model, validated."""
    _kind(t, "narma")
    od = t.table("orders", expected="an object")
    orders = NarmaOrders(
        n=od.int("n", lo=1, hi=MAX_ORDER),
        m=od.int("m", lo=1, hi=MAX_ORDER),
        p=od.int("p", lo=0, hi=MAX_ORDER),
        q=od.int("q", lo=0, hi=MAX_ORDER),
    )
    period = t.float("period_s", positive=True, expected="a positive number (s)")
    if expect_period_s is not None and not math.isclose(period, expect_period_s, rel_tol=1e-9):
        raise t.fail("period_s", f"{expect_period_s} s (the control period it is loaded for)", period)
    T_ref = t.float("T_ref_C", lo=-50.0, hi=150.0, expected="a temperature in [-50, 150] °C")
    cr = _range(t, "current_range_A")
    if max(abs(cr[0]), abs(cr[1])) > MAX_CURRENT_A:
        raise t.fail("current_range_A", f"a current range within ±{MAX_CURRENT_A:g} A", list(cr))
    Tr = _range(t, "T_range_C") if t.has("T_range_C") else (T_ref, T_ref)
    theta = _numbers(t, "theta", length=orders.d)
    if t.has("columns") and t.raw["columns"] != orders.column_names():
        raise t.fail(
            "columns", f"the regressors of orders {orders.as_dict()} in θ order", str(t.raw["columns"])
        )
    sha = t.get("data_sha256", "")
    if not isinstance(sha, str) or (sha and not re.fullmatch(r"[0-9a-f]{64}", sha)):
        raise t.fail("data_sha256", "'' or 64 lower-case hex digits", sha)
    temp = NarmaModel(
        orders=orders,
        theta=theta,
        period_s=period,
        T_ref_C=T_ref,
        current_range_A=cr,
        T_range_C=Tr,
        metrics=_metrics(t),
        data_sha256=sha,
    )
    if check_stability:
        rep = _check(temp)
        if not rep.stable:
            raise t.fail("theta", "a stable model", rep.reason)
    return temp


def _flux(f: Section, period: float) -> FluxArma:
    """The document's ``flux`` (ARMA) model, validated; ``period``: the temperature model's, s."""
    _kind(f, "arma")
    fp = f.float("period_s", positive=True, expected="a positive number (s)")
    if not math.isclose(fp, period, rel_tol=1e-9):
        raise f.fail("period_s", f"the temperature model's period {period} s", fp)
    c = _numbers(f, "c", min_len=1, max_len=MAX_ORDER)
    d = _numbers(f, "d", min_len=1, max_len=MAX_ORDER + 1)
    m = len(d) - 1
    e, g, h = (_numbers(f, k, min_len=0, max_len=m) if f.has(k) else np.zeros(0) for k in "egh")
    if len(e) not in (0, m) or not len(g) == len(h) == len(e):
        raise f.fail(
            "e",
            f"'e', 'g', 'h' all empty or all of {m} numbers (len(d) - 1)",
            f"{len(e)}, {len(g)} and {len(h)} values",
        )
    flux = FluxArma(c=c, d=d, e=e, g=g, h=h, period_s=fp, T_ref_C=f.float("T_ref_C"), metrics=_metrics(f))
    if np.max(np.abs(flux.poles())) >= 1.0:
        raise f.fail("c", "a stable ARMA model (poles inside the unit circle)", list(map(float, c)))
    return flux


def _capacity(cd: Section) -> CapacityModel:
    """The document's ``capacity`` (eq. 13) model, validated."""
    _kind(cd, "capacity-eq13")
    return CapacityModel(
        theta=_numbers(cd, "theta", length=5),
        current_range_A=_range(cd, "current_range_A"),
        metrics=_metrics(cd),
    )


def load_model(
    path: str | os.PathLike[str], *, check_stability: bool = True, expect_period_s: float | None = None
) -> TemModel:
    """Read and validate a model file (see the module docstring), through
    :func:`telethermo.inputfile.load_json`.

    Args:
        path: the JSON file.
        check_stability: also run :func:`telethermo.ident.stability.check_stability` (~0.1 s).
        expect_period_s: if given, the model's sample period must equal it (the node's control period).

    Raises:
        ModelFileError: naming the file, the field (or the line) and what was expected.
    """
    doc = load_json(path, "a TEM model file (telethermo identify --out)", ModelFileError)
    return read_model(doc, check_stability=check_stability, expect_period_s=expect_period_s)
