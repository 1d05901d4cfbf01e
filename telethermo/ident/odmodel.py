"""An identified model in a node's object dictionary (0x2300..0x2311): the values to write, the model
read back from them, and the CRC-32 that proves a transfer.

Objects (bus_config/edsgen.py is the source of truth for their types and ranges)::

    0x2300..0x2303  narma_n, narma_m, narma_p, narma_q   UNSIGNED8   NARMA orders (eq. 10)
    0x2304          model_period_s                       REAL32      s
    0x2305          model_T_ref_C                        REAL32      °C
    0x2306          theta_len                            UNSIGNED8   valid entries of 0x2310
    0x2307, 0x2308  flux_n, flux_m                       UNSIGNED8   heat-flux model orders (eq. 12)
    0x230A, 0x230B  model_I_min_A, model_I_max_A         REAL64      A, current range of the training data
    0x230C          flux_with_current                    BOOLEAN     flux coefficients include e, g, h
    0x2310:1..      theta                                REAL64      NARMA parameters (eq. 11 order)
    0x2311:1..      flux_coeffs                          REAL64      c_1..c_n, d_0..d_m
                                                                     [, e_1..e_m, g_1..g_m, h_1..h_m]

and the commands: 0x230D model_command (write 1: load what 0x2300..0x2311 hold, 2: unload), 0x230E
model_status (0 none, 1 loaded, 2 edited since loaded), 0x230F model_crc32 (of the loaded model's
entries, :func:`od_crc32`).

This is the one model <-> object-dictionary API (the nodes, ``telethermo identify`` and the tests use it).

The coefficients are REAL64: at 10 ms the AR coefficients of a TEM model nearly cancel (1 - Σα ≈ 2e-8
for the shipped model, whose slowest pole is the heat sink's, 0.9996), far below REAL32's resolution of
~5e-7 on coefficients of magnitude ~4; REAL32 rounding (:func:`round_real32`) makes such a model unstable
(:func:`model_from_od` then refuses it) or wrong by degrees (8 °C in a free run of the shipped model,
measured in tests/ident/test_modelfile.py). The period and the reference temperature are REAL32: a node's
model differs from its file by their rounding only (< 1e-6 °C on T_ref).

The capacity model (eq. 13) has no objects: it stays in the model file.
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass
from typing import Any, Callable, cast

import numpy as np
from canopen.objectdictionary import ODVariable
from canopen.objectdictionary import datatypes as dt

from telethermo.ident import stability
from telethermo.ident.flux import FluxArma
from telethermo.ident.modelfile import ModelFileError, TemModel
from telethermo.ident.narma import NarmaModel, NarmaOrders

THETA_INDEX, FLUX_INDEX = 0x2310, 0x2311
THETA_MAX, FLUX_MAX = 48, 16
COMMAND_INDEX, STATUS_INDEX, CRC_INDEX = 0x230D, 0x230E, 0x230F
CMD_LOAD, CMD_UNLOAD = 1, 2
STATUS_NONE, STATUS_LOADED, STATUS_EDITED = 0, 1, 2
STATUS_NAMES = {STATUS_NONE: "none", STATUS_LOADED: "loaded", STATUS_EDITED: "edited (not loaded)"}

#: a model object's kind -> its encoding, from canopen's own table of the CiA 301 types
_PACK: dict[str, struct.Struct] = {
    kind: ODVariable.STRUCT_TYPES[code]
    for kind, code in (("u8", dt.UNSIGNED8), ("f32", dt.REAL32), ("f64", dt.REAL64), ("bool", dt.BOOLEAN))
}
#: the scalar model objects: name -> (index, kind)
SCALARS: dict[str, tuple[int, str]] = {
    "narma_n": (0x2300, "u8"),
    "narma_m": (0x2301, "u8"),
    "narma_p": (0x2302, "u8"),
    "narma_q": (0x2303, "u8"),
    "model_period_s": (0x2304, "f32"),
    "model_T_ref_C": (0x2305, "f32"),
    "theta_len": (0x2306, "u8"),
    "flux_n": (0x2307, "u8"),
    "flux_m": (0x2308, "u8"),
    "model_I_min_A": (0x230A, "f64"),
    "model_I_max_A": (0x230B, "f64"),
    "flux_with_current": (0x230C, "bool"),
}
#: every index that holds a part of the model (a write to one of them edits the model)
MODEL_INDICES = frozenset(i for i, _ in SCALARS.values()) | {THETA_INDEX, FLUX_INDEX}


@dataclass(frozen=True)
class Entry:
    """One object value of a model: ``index``:``sub`` of ``kind`` ('u8', 'f32', 'f64', 'bool')."""

    index: int
    sub: int
    kind: str
    value: Any
    name: str = ""

    def pack(self) -> bytes:
        return _PACK[self.kind].pack(self.value)


def round_real32(x: float) -> float:
    """``x`` rounded to IEEE-754 single precision (what a REAL32 object holds)."""
    return cast(float, struct.unpack("<f", struct.pack("<f", x))[0])


def flux_coefficients(flux: FluxArma) -> list[float]:
    """c_1..c_n, d_0..d_m, then e, g, h when the model has current terms."""
    parts = [flux.c, flux.d] + ([flux.e, flux.g, flux.h] if flux.with_current else [])
    return [float(v) for p in parts for v in p]


def model_entries(tem: TemModel) -> list[Entry]:
    """The object values of ``tem``, in the order a client writes them (scalars, then the arrays).

    Raises ModelFileError if the model does not fit the objects (more than 48 θ or 16 flux coefficients,
    orders above the objects' ranges, a flux model at another period or reference temperature).
    """
    m = tem.temperature
    o = m.orders
    src = "model"
    if o.d > THETA_MAX:
        raise ModelFileError(
            src, "theta", f"at most {THETA_MAX} parameters (object 0x2310)", f"{o.d} for orders {o.as_dict()}"
        )
    vals: dict[str, Any] = {
        "narma_n": o.n,
        "narma_m": o.m,
        "narma_p": o.p,
        "narma_q": o.q,
        "model_period_s": round_real32(m.period_s),
        "model_T_ref_C": round_real32(m.T_ref_C),
        "theta_len": o.d,
        "model_I_min_A": float(m.current_range_A[0]),
        "model_I_max_A": float(m.current_range_A[1]),
    }
    coeffs: list[float] = []
    f = tem.flux
    if f is not None:
        coeffs = flux_coefficients(f)
        if len(coeffs) > FLUX_MAX:
            raise ModelFileError(
                src, "flux", f"at most {FLUX_MAX} coefficients (object 0x2311)", f"{len(coeffs)}"
            )
        if abs(f.period_s - m.period_s) > 1e-12 or abs(f.T_ref_C - m.T_ref_C) > 1e-9:
            raise ModelFileError(
                src,
                "flux",
                "the temperature model's period and reference temperature",
                f"{f.period_s} s, {f.T_ref_C} °C",
            )
    vals.update(
        flux_n=f.c.size if f is not None else 0,
        flux_m=f.d.size - 1 if f is not None else 0,
        flux_with_current=bool(f is not None and f.with_current),
    )
    out = [Entry(idx, 0, kind, vals[k], k) for k, (idx, kind) in SCALARS.items()]
    out += [Entry(THETA_INDEX, i, "f64", float(t), f"theta{i}") for i, t in enumerate(m.theta, start=1)]
    out += [Entry(FLUX_INDEX, i, "f64", c, f"flux_coeff{i}") for i, c in enumerate(coeffs, start=1)]
    return out


def od_crc32(entries: list[Entry]) -> int:
    """CRC-32 (zlib) of the entries' little-endian encodings, in order: what a node reports in 0x230F for
    the model it runs, and what a client computes over what it wrote."""
    crc = 0
    for e in entries:
        crc = zlib.crc32(e.pack(), crc)
    return crc & 0xFFFFFFFF


def model_from_od(
    read: Callable[[int, int], Any],
    *,
    source: str = "object dictionary",
    period_s: float | None = None,
    check_stability: bool = True,
    stability_samples: int = 6000,
) -> tuple[TemModel, list[Entry]]:
    """The model held in the objects (``read(index, sub)`` returns a decoded value) and its entries.

    Validated as a model file is: orders, θ count, finite values, the flux layout, ``period_s`` (the
    node's SYNC period, if given, within REAL32 rounding) and stability (local poles over the current
    range plus a ``stability_samples`` PRBS free run; see :func:`telethermo.ident.stability.check_stability`).
    Raises :class:`ModelFileError` naming the object.
    """
    vals = {k: read(idx, 0) for k, (idx, _) in SCALARS.items()}
    try:
        orders = NarmaOrders(
            n=int(vals["narma_n"]), m=int(vals["narma_m"]), p=int(vals["narma_p"]), q=int(vals["narma_q"])
        )
    except ValueError as exc:
        raise ModelFileError(source, "narma_n..narma_q (0x2300..0x2303)", "valid orders", str(exc)) from None
    d = int(vals["theta_len"])
    if d != orders.d:
        raise ModelFileError(
            source, "theta_len (0x2306)", f"{orders.d} for orders {orders.as_dict()}", str(d)
        )
    theta = [float(read(THETA_INDEX, i)) for i in range(1, d + 1)]
    per = float(vals["model_period_s"])
    if period_s is not None and abs(per - period_s) > 1e-6 * period_s:
        raise ModelFileError(
            source, "model_period_s (0x2304)", f"the node's SYNC period {period_s} s", f"{per} s"
        )
    lo, hi = float(vals["model_I_min_A"]), float(vals["model_I_max_A"])
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ModelFileError(
            source, "model_I_min_A/model_I_max_A (0x230A/0x230B)", "a range lo < hi, A", f"{lo}..{hi}"
        )
    if not all(math.isfinite(t) for t in theta):
        raise ModelFileError(source, "theta (0x2310)", "finite numbers", "a NaN or infinity")
    T_ref = float(vals["model_T_ref_C"])
    try:
        model = NarmaModel(
            orders=orders,
            theta=np.array(theta),
            period_s=per,
            T_ref_C=T_ref,
            current_range_A=(lo, hi),
            T_range_C=(T_ref, T_ref),
        )
    except ValueError as exc:
        raise ModelFileError(source, "", "a valid model", str(exc)) from None
    if check_stability:
        rep = stability.check_stability(model, n_samples=stability_samples)
        if not rep.stable:
            raise ModelFileError(
                source,
                "theta (0x2310)",
                "a stable model (REAL64 coefficients: REAL32 rounding makes an identified model unstable)",
                rep.reason,
            )
    flux, count = _flux_from_od(read, vals, source, per, T_ref)
    tem = TemModel(temperature=model, flux=flux, meta={"source": source})
    entries = [Entry(SCALARS[k][0], 0, SCALARS[k][1], v, k) for k, v in vals.items()]
    entries += [Entry(THETA_INDEX, i, "f64", t, f"theta{i}") for i, t in enumerate(theta, start=1)]
    entries += [
        Entry(FLUX_INDEX, i, "f64", float(read(FLUX_INDEX, i)), f"flux_coeff{i}") for i in range(1, count + 1)
    ]
    return tem, entries


def _flux_from_od(
    read: Callable[[int, int], Any], vals: dict[str, Any], source: str, per: float, T_ref: float
) -> tuple[FluxArma | None, int]:
    """The heat-flux model held in the objects (None when ``flux_n`` is 0) and its coefficient count;
    ``per``: the model period, s; ``T_ref``: its reference temperature, °C."""
    fn, fm, with_i = int(vals["flux_n"]), int(vals["flux_m"]), bool(vals["flux_with_current"])
    flux = None
    count = 0
    if fn:
        count = fn + fm + 1 + (3 * fm if with_i else 0)
        if count > FLUX_MAX:
            raise ModelFileError(
                source, "flux_n/flux_m (0x2307/0x2308)", f"at most {FLUX_MAX} coefficients", str(count)
            )
        c = [float(read(FLUX_INDEX, i)) for i in range(1, count + 1)]
        if not all(math.isfinite(x) for x in c):
            raise ModelFileError(source, "flux_coeffs (0x2311)", "finite numbers", "a NaN or infinity")
        parts = np.split(np.array(c), np.cumsum([fn, fm + 1, fm, fm])[: 4 if with_i else 1])
        current_terms: dict[str, Any] = {"e": parts[2], "g": parts[3], "h": parts[4]} if with_i else {}
        try:
            flux = FluxArma(c=parts[0], d=parts[1], period_s=per, T_ref_C=T_ref, **current_terms)
        except ValueError as exc:
            raise ModelFileError(
                source, "flux_coeffs (0x2311)", "a valid heat-flux model", str(exc)
            ) from None
    return flux, count
