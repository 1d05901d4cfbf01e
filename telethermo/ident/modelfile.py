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

import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, overload

import numpy as np

from telethermo.atomic import write_json_atomic
from telethermo.ident.capacity import CapacityModel
from telethermo.ident.flux import FluxArma
from telethermo.ident.narma import MAX_ORDER, NarmaModel, NarmaOrders
from telethermo.ident.stability import check_stability as _check
from telethermo.units import MODEL_KINDS, base_unit

FORMAT = "telethermo-tem-model"
FORMAT_VERSION = 1
#: the unit of each quantity in a model file (kind -> unit name of the one unit table)
UNITS = {kind: base_unit(kind) for kind in MODEL_KINDS}


class ModelFileError(ValueError):
    """A model file is missing, malformed, inconsistent or holds an unstable model.

    Attributes: ``path`` (the file), ``field`` (dotted JSON path, '' for the whole file), ``expected``
    (what was expected), ``got`` (what was found, short).
    """

    def __init__(self, path: str | os.PathLike[str], field: str, expected: str, got: str = "") -> None:
        self.path, self.field, self.expected, self.got = str(path), field, expected, got
        where = f"field '{field}': " if field else ""
        tail = f", got {got}" if got else ""
        super().__init__(f"model file {self.path}: {where}expected {expected}{tail}")


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


def _is_finite(v: int | float) -> bool:
    """True for a number a float can hold (JSON integers have no size limit)."""
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


class _Reader:
    """Typed field access that raises ModelFileError with the dotted field name."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = path

    def err(self, fld: str, expected: str, got: Any = "") -> ModelFileError:
        g = got if isinstance(got, str) else repr(got)
        return ModelFileError(self.path, fld, expected, g[:80])

    @overload
    def obj(
        self, parent: dict[str, Any], key: str, fld: str, *, optional: Literal[False] = False
    ) -> dict[str, Any]: ...
    @overload
    def obj(self, parent: dict[str, Any], key: str, fld: str, *, optional: bool) -> dict[str, Any] | None: ...

    def obj(
        self, parent: dict[str, Any], key: str, fld: str, *, optional: bool = False
    ) -> dict[str, Any] | None:
        if key not in parent:
            if optional:
                return None
            raise self.err(fld, "an object (missing)")
        v = parent[key]
        if v is None and optional:
            return None
        if not isinstance(v, dict):
            raise self.err(fld, "an object", v)
        return v

    def num(self, parent: dict[str, Any], key: str, fld: str, *, positive: bool = False) -> float:
        if key not in parent:
            raise self.err(fld, "a number (missing)")
        v = parent[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not _is_finite(v):
            raise self.err(fld, "a finite number", v)
        if positive and v <= 0:
            raise self.err(fld, "a positive number", v)
        return float(v)

    def int_(self, parent: dict[str, Any], key: str, fld: str, lo: int, hi: int) -> int:
        v = parent.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise self.err(fld, f"an integer in [{lo}, {hi}]", "missing" if key not in parent else v)
        return v

    def nums(
        self,
        parent: dict[str, Any],
        key: str,
        fld: str,
        *,
        length: int | None = None,
        min_len: int = 1,
        max_len: int = 10_000,
    ) -> np.ndarray:
        v = parent.get(key)
        want = (
            f"a list of {length} finite numbers"
            if length is not None
            else f"a list of {min_len}..{max_len} finite numbers"
        )
        if not isinstance(v, list):
            raise self.err(fld, want, "missing" if key not in parent else v)
        if (length is not None and len(v) != length) or not (min_len <= len(v) <= max_len):
            raise self.err(fld, want, f"{len(v)} values")
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not _is_finite(x):
                raise self.err(f"{fld}[{i}]", "a finite number", x)
        return np.asarray(v, dtype=float)

    def range_(self, parent: dict[str, Any], key: str, fld: str) -> tuple[float, float]:
        lo, hi = self.nums(parent, key, fld, length=2)
        if lo > hi:
            raise self.err(fld, "[min, max] with min <= max", [lo, hi])
        return float(lo), float(hi)

    def metrics(self, parent: dict[str, Any], fld: str) -> dict[str, Any]:
        m = parent.get("metrics", {})
        if m is None:
            return {}
        if not isinstance(m, dict):
            raise self.err(fld, "an object", m)
        return m


def model_from_dict(
    doc: Any,
    *,
    path: str | os.PathLike[str] = "<dict>",
    check_stability: bool = True,
    expect_period_s: float | None = None,
) -> TemModel:
    """Validate a model document and build the :class:`TemModel` (errors: :class:`ModelFileError`)."""
    r = _Reader(path)
    if not isinstance(doc, dict):
        raise r.err("", "a JSON object at the top level", type(doc).__name__)
    if doc.get("format") != FORMAT:
        raise r.err("format", f"'{FORMAT}'", doc.get("format", "missing"))
    if doc.get("format_version") != FORMAT_VERSION:
        raise r.err(
            "format_version",
            f"{FORMAT_VERSION} (the version this program reads)",
            doc.get("format_version", "missing"),
        )
    units = doc.get("units", UNITS)
    if units != UNITS:
        raise r.err("units", f"{UNITS}", units)
    temp = _temperature_from_dict(r, doc, check_stability, expect_period_s)
    flux = _flux_from_dict(r, doc, temp.period_s)
    cap = _capacity_from_dict(r, doc)
    meta = doc.get("meta", {})
    if not isinstance(meta, dict):
        raise r.err("meta", "an object", meta)
    return TemModel(temperature=temp, flux=flux, capacity=cap, meta=meta)


def _temperature_from_dict(
    r: _Reader, doc: dict[str, Any], check_stability: bool, expect_period_s: float | None
) -> NarmaModel:
    """The document's ``temperature`` (NARMA) model, validated."""
    t = r.obj(doc, "temperature", "temperature")
    if t.get("kind") != "narma":
        raise r.err("temperature.kind", "'narma'", t.get("kind", "missing"))
    od = r.obj(t, "orders", "temperature.orders")
    orders = NarmaOrders(
        n=r.int_(od, "n", "temperature.orders.n", 1, MAX_ORDER),
        m=r.int_(od, "m", "temperature.orders.m", 1, MAX_ORDER),
        p=r.int_(od, "p", "temperature.orders.p", 0, MAX_ORDER),
        q=r.int_(od, "q", "temperature.orders.q", 0, MAX_ORDER),
    )
    period = r.num(t, "period_s", "temperature.period_s", positive=True)
    if expect_period_s is not None and not math.isclose(period, expect_period_s, rel_tol=1e-9):
        raise r.err(
            "temperature.period_s", f"{expect_period_s} s (the control period it is loaded for)", period
        )
    T_ref = r.num(t, "T_ref_C", "temperature.T_ref_C")
    if not -50.0 <= T_ref <= 150.0:
        raise r.err("temperature.T_ref_C", "a temperature in [-50, 150] °C", T_ref)
    cr = r.range_(t, "current_range_A", "temperature.current_range_A")
    if max(abs(cr[0]), abs(cr[1])) > MAX_CURRENT_A:
        raise r.err("temperature.current_range_A", f"a current range within ±{MAX_CURRENT_A:g} A", list(cr))
    Tr = r.range_(t, "T_range_C", "temperature.T_range_C") if "T_range_C" in t else (T_ref, T_ref)
    theta = r.nums(t, "theta", "temperature.theta", length=orders.d)
    if "columns" in t and t["columns"] != orders.column_names():
        raise r.err(
            "temperature.columns",
            f"the regressors of orders {orders.as_dict()} in θ order",
            str(t["columns"]),
        )
    sha = t.get("data_sha256", "")
    if not isinstance(sha, str) or (sha and not re.fullmatch(r"[0-9a-f]{64}", sha)):
        raise r.err("temperature.data_sha256", "'' or 64 lower-case hex digits", sha)
    temp = NarmaModel(
        orders=orders,
        theta=theta,
        period_s=period,
        T_ref_C=T_ref,
        current_range_A=cr,
        T_range_C=Tr,
        metrics=r.metrics(t, "temperature.metrics"),
        data_sha256=sha,
    )
    if check_stability:
        rep = _check(temp)
        if not rep.stable:
            raise r.err("temperature.theta", "a stable model", rep.reason)
    return temp


def _flux_from_dict(r: _Reader, doc: dict[str, Any], period: float) -> FluxArma | None:
    """The document's optional ``flux`` (ARMA) model, validated; ``period``: the temperature model's, s."""
    f = r.obj(doc, "flux", "flux", optional=True)
    if f is None:
        return None
    if f.get("kind") != "arma":
        raise r.err("flux.kind", "'arma'", f.get("kind", "missing"))
    fp = r.num(f, "period_s", "flux.period_s", positive=True)
    if not math.isclose(fp, period, rel_tol=1e-9):
        raise r.err("flux.period_s", f"the temperature model's period {period} s", fp)
    c = r.nums(f, "c", "flux.c", min_len=1, max_len=MAX_ORDER)
    d = r.nums(f, "d", "flux.d", min_len=1, max_len=MAX_ORDER + 1)
    m = len(d) - 1
    e = r.nums(f, "e", "flux.e", min_len=0, max_len=m) if "e" in f else np.zeros(0)
    g = r.nums(f, "g", "flux.g", min_len=0, max_len=m) if "g" in f else np.zeros(0)
    h = r.nums(f, "h", "flux.h", min_len=0, max_len=m) if "h" in f else np.zeros(0)
    if len(e) not in (0, m) or not len(g) == len(h) == len(e):
        raise r.err(
            "flux.e",
            f"'e', 'g', 'h' all empty or all of {m} numbers (len(d) - 1)",
            f"{len(e)}, {len(g)} and {len(h)} values",
        )
    flux = FluxArma(
        c=c,
        d=d,
        e=e,
        g=g,
        h=h,
        period_s=fp,
        T_ref_C=r.num(f, "T_ref_C", "flux.T_ref_C"),
        metrics=r.metrics(f, "flux.metrics"),
    )
    if np.max(np.abs(flux.poles())) >= 1.0:
        raise r.err("flux.c", "a stable ARMA model (poles inside the unit circle)", list(map(float, c)))
    return flux


def _capacity_from_dict(r: _Reader, doc: dict[str, Any]) -> CapacityModel | None:
    """The document's optional ``capacity`` (eq. 13) model, validated."""
    cd = r.obj(doc, "capacity", "capacity", optional=True)
    if cd is None:
        return None
    if cd.get("kind") != "capacity-eq13":
        raise r.err("capacity.kind", "'capacity-eq13'", cd.get("kind", "missing"))
    cap = CapacityModel(
        theta=r.nums(cd, "theta", "capacity.theta", length=5),
        current_range_A=r.range_(cd, "current_range_A", "capacity.current_range_A"),
        metrics=r.metrics(cd, "capacity.metrics"),
    )
    return cap


def load_model(
    path: str | os.PathLike[str], *, check_stability: bool = True, expect_period_s: float | None = None
) -> TemModel:
    """Read and validate a model file (see the module docstring).

    Args:
        path: the JSON file.
        check_stability: also run :func:`telethermo.ident.stability.check_stability` (~0.1 s).
        expect_period_s: if given, the model's sample period must equal it (the node's control period).

    Raises:
        ModelFileError: naming the file, the field and what was expected.
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ModelFileError(path, "", "an existing file", "no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(path, "", "a readable UTF-8 file", str(exc)) from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ModelFileError(
            path, "", "valid JSON", f"{exc.msg} at line {exc.lineno} column {exc.colno}"
        ) from None
    return model_from_dict(doc, path=path, check_stability=check_stability, expect_period_s=expect_period_s)
