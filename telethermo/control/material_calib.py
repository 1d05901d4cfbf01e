"""Calibrated material classifier: the touch's own transient, classified by a network trained on
reference touches.

Why: the physics estimator (telethermo.control.material_id) fits a lumped probe model that its bias limits
(the sensor's graded transient, its lower half driven by the controller, the first ~50 ms); and the
probe's response is not even proportional to the temperature difference (the controller's contact
detection and the TEM's Joule heat), so no fixed model of the kind fits it. Material-recognition sensors
are calibrated on reference samples instead; so is this classifier.

The touch vector (:func:`touch_vector`, °C): the filtered T_sensor's change since the pre-contact mean over
the 0.3 s window, then the flux's change times ``q_weight_K_per_W``. The network's input
(:func:`network_input`) is that vector less the references' mean, whitened by the covariance of the rig's
noise in it (:func:`whitener`: in units of that noise, the fast components that tell the materials apart are
not drowned by the large slow ones that object temperature and force move) and divided by one overall scale.
The classifier (:func:`classify_vector`) is a small ensemble of fully connected ReLU networks, each trained
(telethermo.control.material_train) to give the posterior of the material over reference touches that vary
force, thickness, object temperature and the touch's instant: those nuisances are marginalised by the
training, not fitted per touch. The ensemble's posterior is the mean of its members'.

Why a network and not the nearest references (the previous form, local affine models of the k nearest):
the local models' own error between references limited those, not the rig's noise (0.857 on noise-free
touches); the network learns the class boundaries instead (docs/material_id.md has the development table).

The file (:func:`save_calibration`, NumPy .npz, written atomically; :func:`load_calibration` names the file
and the field of any malformed entry) carries the period and window it was measured with: a calibration is
valid only for the probe, controller, rest temperature and sampling it was measured on.
"""

from __future__ import annotations

import io
import math
import zipfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.lib.npyio import NpzFile

from telethermo.atomic import write_bytes_atomic
from telethermo.control.material_id import FitInput

#: the shipped calibration (bench/material_calibrate.py, simulated reference touches)
DEFAULT_CALIBRATION = Path(__file__).resolve().parent.parent / "data" / "material_classifier.npz"
#: the shipped envelope classifiers of the early (0.3 s) and the refined (1.2 s) answer
#: (telethermo.offline.material_envelope_calibration)
ENVELOPE_EARLY = DEFAULT_CALIBRATION.with_name("material_envelope_early.npz")
ENVELOPE_LATE = DEFAULT_CALIBRATION.with_name("material_envelope_late.npz")
#: the early classifier the refined answer pools with (0.3 s; the pool's weights are fitted with it)
ENVELOPE_POOL = DEFAULT_CALIBRATION.with_name("material_envelope_pool.npz")
FORMAT = "telethermo-material-classifier-2"


@dataclass(frozen=True, eq=False)
class Calibration:
    """A calibrated classifier.

    Attributes:
        classes: rendering-table names, the networks' outputs in this order.
        dt_s: sampling period it was measured with, s; n_win: window samples after the touch.
        q_weight_K_per_W: the flux's weight in the touch vector, K/W.
        center: mean reference touch vector (2·n_win, °C).
        whiten: the noise's whitening (2·n_win square, 1/°C: :func:`whitener`; the identity in 1/°C without a
            noise covariance); scale: the whitened references' overall standard deviation. The networks' input
            is whiten·(v − center)/scale, dimensionless and of order one.
        nets: the ensemble's members, each its layers' (weights (in × out), biases (out)) as float32; ReLU
            between layers, softmax after the last.
        info: how it was calibrated (JSON text), for the record.
        features: what it classifies: "touch" (:func:`touch_vector`, the in-box classifier) or "envelope"
            (:func:`envelope_vector`, the envelope classifier, every ``sub``-th sample); the input map of an
            envelope classifier standardises each feature (``whiten`` diagonal, ``scale`` 1).
        x_lo, x_hi: the lowest and highest value of each network input over the references it was trained
            on (None: not recorded): a touch beyond them lies outside what it learnt
            (:func:`outside_references`).
        pool: the refined answer's log-linear pool with the early answer's classifier: (weight of the early
            classifier's ln posterior, weight of this one's), fitted on development touches (:func:`pooled`;
            None: this classifier alone).
    """

    classes: tuple[str, ...]
    dt_s: float
    n_win: int
    q_weight_K_per_W: float
    center: np.ndarray
    whiten: np.ndarray
    scale: float
    nets: tuple[tuple[tuple[np.ndarray, np.ndarray], ...], ...]
    info: str = ""
    features: str = "touch"
    sub: int = 1
    x_lo: np.ndarray | None = None
    x_hi: np.ndarray | None = None
    pool: tuple[float, float] | None = None


def pooled(p_early: np.ndarray, p_late: np.ndarray, pool: tuple[float, float]) -> np.ndarray:
    """The log-linear pool of two classifiers' posteriors over the same classes (pure): softmax of
    ``pool[0]``·ln p_early + ``pool[1]``·ln p_late. The early answer's classifier sees the touch's first 0.3 s
    at every sample, the refined one 1.2 s at every 4th: each knows what the other blurs, and the weights
    (fitted by likelihood) say how much of their evidence is shared."""
    ln_e = np.log(np.maximum(np.asarray(p_early, float), 1e-30))
    ln_l = np.log(np.maximum(np.asarray(p_late, float), 1e-30))
    return cast(np.ndarray, np.exp(log_softmax(pool[0] * ln_e + pool[1] * ln_l)))


def with_ranges(cal: Calibration, X: np.ndarray) -> Calibration:
    """``cal`` with the range of its references' network inputs ``X`` (touches × inputs) recorded."""
    X = np.asarray(X, float)
    if X.ndim != 2 or X.shape[1] != cal.center.size:
        raise ValueError(f"expected touches × {cal.center.size} network inputs, got {X.shape}")
    return replace(cal, x_lo=X.min(axis=0), x_hi=X.max(axis=0))


def outside_references(cal: Calibration, x: np.ndarray, margin: float) -> bool:
    """Whether network input ``x`` lies beyond the references' range (:func:`with_ranges`) by more than
    ``margin`` in any input (the inputs are standardised: ``margin`` is in the references' standard
    deviations). False when the calibration has no recorded range (pure)."""
    if cal.x_lo is None or cal.x_hi is None:
        return False
    x = np.asarray(x, float)
    return bool(np.any(x < cal.x_lo - margin) or np.any(x > cal.x_hi + margin))


def touch_vector(inp: FitInput, q_weight_K_per_W: float) -> np.ndarray:
    """[T_sensor − pre-contact mean (°C) over the window, (Q − pre-contact mean)·q_weight (°C)] (pure)."""
    n = inp.n_pre
    dT = inp.T[n:] - float(np.mean(inp.T[:n]))
    dQ = (inp.Q[n:] - float(np.mean(inp.Q[:n]))) * q_weight_K_per_W
    return np.concatenate([dT, dQ])


def envelope_vector(inp: FitInput, q_weight_K_per_W: float, sub: int) -> np.ndarray:
    """The envelope classifier's touch features (pure): the touch vector over the window (every ``sub``-th
    sample, the last of each group), divided by its own length and by the direction of the heat flow (so that
    a touch of an object hotter than the probe has the shape of a colder one's), then ln of that length
    (°C), the direction (+1: heat into the object), the probe's pre-contact temperature (°C) and its
    pre-contact flux times ``q_weight_K_per_W`` (°C). The object's temperature difference sets the length,
    the material and the contact the shape: physics that the network then need not learn from examples."""
    n = inp.n_pre
    T0, Q0 = float(np.mean(inp.T[:n])), float(np.mean(inp.Q[:n]))
    dT = (inp.T[n:] - T0)[sub - 1 :: sub]
    dQ = ((inp.Q[n:] - Q0) * q_weight_K_per_W)[sub - 1 :: sub]
    v = np.concatenate([dT, dQ])
    length = float(np.linalg.norm(v)) + 1e-9
    sign = 1.0 if float(np.sum(dQ)) >= 0.0 else -1.0
    return np.concatenate([v * (sign / length), [math.log(length), sign, T0, Q0 * q_weight_K_per_W]])


def calibration_vector(cal: Calibration, inp: FitInput) -> np.ndarray:
    """The vector calibration ``cal`` classifies for window ``inp``: :func:`touch_vector` or, for an envelope
    classifier (``features`` "envelope"), :func:`envelope_vector`."""
    if cal.features == "envelope":
        return envelope_vector(inp, cal.q_weight_K_per_W, cal.sub)
    return touch_vector(inp, cal.q_weight_K_per_W)


def vector_size(features: str, n_win: int, sub: int) -> int:
    """Length of the vector of a calibration of ``features`` over ``n_win`` samples (every ``sub``-th)."""
    return 2 * len(range(sub - 1, n_win, sub)) + 4 if features == "envelope" else 2 * n_win


def network_input(cal: Calibration, v: np.ndarray) -> np.ndarray | None:
    """The networks' input for touch vector ``v`` (float32), or None when it was measured with another window
    or is not finite."""
    if v.shape != cal.center.shape or not np.isfinite(v).all():
        return None
    return inputs(cal.center, cal.whiten, cal.scale, v)


def inputs(center: np.ndarray, whiten: np.ndarray, scale: float, V: np.ndarray) -> np.ndarray:
    """The networks' inputs (float32) of touch vectors ``V`` (one, or N × 2·n_win; °C), unchecked (pure)."""
    return cast(np.ndarray, ((np.asarray(V, float) - center) @ whiten.T / scale).astype(np.float32))


def log_softmax(o: np.ndarray) -> np.ndarray:
    """ln of the softmax over the last axis (pure, stable)."""
    o = o - o.max(axis=-1, keepdims=True)
    return cast(np.ndarray, o - np.log(np.exp(o).sum(axis=-1, keepdims=True)))


def layer(W: np.ndarray, b: np.ndarray, h: np.ndarray, last: bool) -> np.ndarray:
    """One layer: h·W + b, ReLU unless it is the network's last (pure)."""
    z = h @ W + b
    return cast(np.ndarray, z if last else np.maximum(z, 0.0))


def logits(layers: tuple[tuple[np.ndarray, np.ndarray], ...], x: np.ndarray) -> np.ndarray:
    """One network's outputs before the softmax for inputs ``x`` (… × in), ReLU between layers (pure)."""
    h = x
    for i, (W, b) in enumerate(layers):
        h = layer(W, b, h, i == len(layers) - 1)
    return h


def posterior(cal: Calibration, x: np.ndarray) -> np.ndarray:
    """The ensemble's posterior over ``cal.classes`` (mean of its members' softmax) for inputs ``x``
    (pure)."""
    return cast(np.ndarray, np.mean([np.exp(log_softmax(logits(net, x))) for net in cal.nets], axis=0))


def n_units(cal: Calibration) -> int:
    """Units of the staged classification (:func:`network_unit`): one per layer of each network."""
    return sum(len(net) for net in cal.nets)


def network_unit(
    cal: Calibration, x: np.ndarray, h: np.ndarray | None, probs: tuple[np.ndarray, ...], k: int
) -> tuple[np.ndarray | None, tuple[np.ndarray, ...]]:
    """Unit ``k`` of the staged classification of input ``x`` (pure): one layer of one network, so that no
    control cycle carries a whole network (a 512 × 512 layer is 0.03 ms here but milliseconds on an emulated
    or small CPU). ``h`` the previous layer's output (None at a network's first), ``probs`` the softmax of the
    networks done so far; returns the new (h, probs)."""
    j, i = 0, k
    while i >= len(cal.nets[j]):
        i, j = i - len(cal.nets[j]), j + 1
    W, b = cal.nets[j][i]
    last = i == len(cal.nets[j]) - 1
    out = layer(W, b, x if i == 0 else cast(np.ndarray, h), last)  # h is set after a network's first layer
    return (None, probs + (np.exp(log_softmax(out)),)) if last else (out, probs)


def decide(probs: tuple[np.ndarray, ...]) -> tuple[int, float]:
    """(index of the likeliest class, its posterior) from the networks' softmax outputs (their mean)."""
    p = np.mean(probs, axis=0)
    i = int(np.argmax(p))
    return i, float(p[i])


def classify_vector(cal: Calibration, v: np.ndarray) -> tuple[int, float] | None:
    """(index of the likeliest class, its posterior) of touch vector ``v``; None when it cannot be classified
    (another window, not finite). The batch form of the slave's staged classification (the same units)."""
    x = network_input(cal, v)
    if x is None:
        return None
    h: np.ndarray | None = None
    probs: tuple[np.ndarray, ...] = ()
    for k in range(n_units(cal)):
        h, probs = network_unit(cal, x, h, probs, k)
    return decide(probs)


def whitener(noise_cov: np.ndarray, reg: float) -> np.ndarray:
    """W with W·(Σ + reg·mean(diag Σ)·I)·Wᵀ = I (pure): the touch vector's measurement noise made white.

    Σ is the covariance of the touch vector's noise (the rig's noise through its low-pass, the pre-contact
    mean and the controller's response to it); the filter leaves it nearly singular at high frequency, where a
    model's own error would be amplified without bound, hence the floor ``reg`` (relative to the mean
    variance)."""
    S = np.asarray(noise_cov, float)
    S = 0.5 * (S + S.T) + reg * float(np.mean(np.diag(S))) * np.eye(S.shape[0])
    return np.linalg.inv(np.linalg.cholesky(S))


def input_map(
    V: np.ndarray, noise_cov: np.ndarray | None, reg: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """(center, whiten, scale) for reference touch vectors ``V`` (N × 2·n_win, °C): their mean, the noise's
    whitening (identity without ``noise_cov``) and the whitened references' overall standard deviation (the
    networks' inputs are then of order one)."""
    V = np.asarray(V, float)
    center = V.mean(axis=0)
    W = whitener(noise_cov, reg) if noise_cov is not None else np.eye(V.shape[1])
    return center, W, float(np.std((V - center) @ W.T))


def _net_fields(cal: Calibration) -> dict[str, np.ndarray]:
    out = {}
    for j, net in enumerate(cal.nets):
        for i, (W, b) in enumerate(net):
            out[f"net{j}_w{i}"], out[f"net{j}_b{i}"] = W.astype(np.float32), b.astype(np.float32)
    return out


def _range_fields(cal: Calibration) -> dict[str, np.ndarray]:
    """The references' input range fields (none when not recorded), and the pool's weights (none unset)."""
    out = {} if cal.x_lo is None or cal.x_hi is None else {"x_lo": cal.x_lo, "x_hi": cal.x_hi}
    return out | ({"pool": np.array(cal.pool, float)} if cal.pool is not None else {})


def save_calibration(cal: Calibration, path: str | Path) -> Path:
    """Write the calibration file atomically (a reader sees the old file or the new one)."""
    buf = io.BytesIO()
    np.savez_compressed(
        buf,
        format=np.array(FORMAT),
        classes=np.array(cal.classes),
        dt_s=np.array(cal.dt_s),
        n_win=np.array(cal.n_win),
        q_weight_K_per_W=np.array(cal.q_weight_K_per_W),
        center=cal.center,
        whiten=cal.whiten,
        scale=np.array(cal.scale),
        n_nets=np.array(len(cal.nets)),
        n_layers=np.array(len(cal.nets[0]) if cal.nets else 0),
        info=np.array(cal.info),
        features=np.array(cal.features),
        sub=np.array(cal.sub),
        **cast(dict[str, Any], _net_fields(cal)),
        **cast(dict[str, Any], _range_fields(cal)),
    )
    return write_bytes_atomic(path, buf.getvalue())


def _field(path: Path, data: NpzFile, key: str, ndim: int) -> np.ndarray:
    """Field ``key`` with ``ndim`` dimensions, or ValueError naming the file and the field."""
    if key not in data.files:
        raise ValueError(f"{path}: missing field {key!r}")
    a = data[key]
    if a.ndim != ndim:
        raise ValueError(f"{path}: field {key!r}: expected {ndim} dimensions, got {a.ndim}")
    if a.dtype.kind in "fi" and not np.isfinite(a).all():
        raise ValueError(f"{path}: field {key!r}: not finite")
    return a


def _scalar(path: Path, data: NpzFile, key: str, lo: float) -> float:
    """Scalar field ``key`` > ``lo``, or ValueError naming the file and the field."""
    a = _field(path, data, key, 0)
    if a.dtype.kind not in "fi" or not float(a) > lo:
        raise ValueError(f"{path}: field {key!r}: expected a number > {lo:g}, got {a!r}")
    return float(a)


def _nets(
    path: Path, data: NpzFile, n_in: int, n_out: int
) -> tuple[tuple[tuple[np.ndarray, np.ndarray], ...], ...]:
    """The ensemble's layers, each checked to chain from ``n_in`` inputs to ``n_out`` classes."""
    n_nets, n_layers = int(_scalar(path, data, "n_nets", 0.0)), int(_scalar(path, data, "n_layers", 0.0))
    nets: list[tuple[tuple[np.ndarray, np.ndarray], ...]] = []
    for j in range(n_nets):
        layers: list[tuple[np.ndarray, np.ndarray]] = []
        width = n_in
        for i in range(n_layers):
            W, b = _field(path, data, f"net{j}_w{i}", 2), _field(path, data, f"net{j}_b{i}", 1)
            out = n_out if i == n_layers - 1 else W.shape[1]
            if W.shape != (width, out) or b.shape != (out,):
                raise ValueError(
                    f"{path}: field 'net{j}_w{i}': expected {width} × {out} weights and {out} biases, "
                    f"got {W.shape} and {b.shape}"
                )
            layers.append((W.astype(np.float32), b.astype(np.float32)))
            width = out
        nets.append(tuple(layers))
    return tuple(nets)


def load_calibration(path: str | Path | None = None) -> Calibration:
    """Read a calibration file (default: the shipped one); ValueError naming the file and the field."""
    path = Path(path) if path is not None else DEFAULT_CALIBRATION
    try:
        data = np.load(path, allow_pickle=False)
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise ValueError(f"{path}: cannot read material classifier: {exc}".replace("\n", " ")) from exc
    with data:
        if "format" not in data.files or str(data["format"]) != FORMAT:
            raise ValueError(f"{path}: field 'format': expected {FORMAT!r}")
        classes = _field(path, data, "classes", 1)
        if classes.dtype.kind != "U" or classes.size < 2:
            raise ValueError(f"{path}: field 'classes': expected ≥ 2 material names")
        dt, qw, scale = (_scalar(path, data, key, 0.0) for key in ("dt_s", "q_weight_K_per_W", "scale"))
        n_win = int(_scalar(path, data, "n_win", 5.0))
        features = str(data["features"]) if "features" in data.files else "touch"
        if features not in ("touch", "envelope"):
            raise ValueError(f"{path}: field 'features': expected 'touch' or 'envelope', got {features!r}")
        sub = int(_scalar(path, data, "sub", 0.0)) if "sub" in data.files else 1
        size = vector_size(features, n_win, sub)
        center, whiten = _field(path, data, "center", 1), _field(path, data, "whiten", 2)
        if center.shape != (size,) or whiten.shape != (center.size, center.size):
            raise ValueError(
                f"{path}: field 'center'/'whiten': expected {size} values per touch (n_win {n_win})"
            )
        nets = _nets(path, data, center.size, classes.size)
        info = str(data["info"]) if "info" in data.files else ""
        x_lo = x_hi = None
        if "x_lo" in data.files or "x_hi" in data.files:
            x_lo, x_hi = _field(path, data, "x_lo", 1), _field(path, data, "x_hi", 1)
            if x_lo.shape != center.shape or x_hi.shape != center.shape or np.any(x_lo > x_hi):
                raise ValueError(
                    f"{path}: field 'x_lo'/'x_hi': expected {center.size} ranges (low ≤ high) per input"
                )
        pool = None
        if "pool" in data.files:
            w = _field(path, data, "pool", 1)
            if w.shape != (2,) or w.dtype.kind != "f" or np.any(w < 0.0):
                raise ValueError(f"{path}: field 'pool': expected two weights >= 0, got {w!r}")
            pool = (float(w[0]), float(w[1]))
        return Calibration(
            tuple(str(c) for c in classes),
            dt,
            n_win,
            qw,
            center.astype(float),
            whiten.astype(float),
            scale,
            nets,
            info,
            features,
            sub,
            x_lo.astype(float) if x_lo is not None else None,
            x_hi.astype(float) if x_hi is not None else None,
            pool,
        )
