"""Calibrated material classifier: the touch's own transient compared with reference touches of known material.

Why: the physics estimator (telethermo.control.material_id) fits a lumped probe model that its bias limits
(the sensor's graded transient, its lower half driven by the controller, the first ~50 ms); and the
probe's response is not even proportional to the temperature difference (the controller's contact
detection and the TEM's Joule heat), so no fixed model of the kind fits it. Material-recognition sensors
are calibrated on reference samples instead; so is this classifier.

The touch vector (:func:`touch_vector`, °C): the filtered T_sensor's change since the pre-contact mean over
the 0.3 s window, then the flux's change times ``q_weight_K_per_W``, whitened by the covariance of the rig's
noise in it (:func:`whitener`: distances in units of that noise, so that the likeliest references are the
nearest) and projected on the reference set's first principal components. Classification (:func:`class_residual`,
:func:`decide`): for each material, the touch's squared distance to the affine span of its ``k`` nearest
reference touches of that material (a local linear model of how force, thickness, object temperature and
the touch's instant move the transient: the nuisances are profiled out locally, as the ceiling's oracle
does with the simulator's own derivatives); the nearest material wins, its posterior is the softmax of
−residual/(2·σ²) with σ² calibrated per degree of freedom (the leave-one-out residual of the right material,
growing with the transient's size).

The file (:func:`save_calibration`, NumPy .npz, written atomically; :func:`load_calibration` names the file
and the field of any malformed entry) carries the period and window it was measured with: a calibration is
valid only for the probe, controller, rest temperature and sampling it was measured on.
"""
from __future__ import annotations

import io
import math
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from telethermo.atomic import write_bytes_atomic
from telethermo.control.material_id import FitInput

#: the shipped calibration (bench/material_calibrate.py, simulated reference touches)
DEFAULT_CALIBRATION = Path(__file__).resolve().parent.parent / "data" / "material_classifier.npz"
FORMAT = "telethermo-material-classifier-1"


@dataclass(frozen=True, eq=False)
class Calibration:
    """A calibrated classifier.

    Attributes:
        classes: rendering-table names, indexed by ``labels``.
        dt_s: sampling period it was measured with, s; n_win: window samples after the touch.
        q_weight_K_per_W: the flux's weight in the touch vector, K/W.
        k: reference touches per local model.
        sigma2: the residual scale of the posterior at zero signal, in the projection's units squared (the
            noise's);
        sigma2_rel: its growth with the touch's squared size |z − z₀|² (z₀: a touch without signal), 1
            (the local models' own error grows with the transient).
        center: mean touch vector (2·n_win, °C); basis: principal components (m × 2·n_win), the noise's
            whitening folded in when it was built with a noise covariance (then the projection is in units of
            the rig's noise, 1/°C·°C: dimensionless; else °C).
        refs: reference touches projected (N × m; stored as float16 when they fit: 3 significant digits;
            on the development set 0.818 against 0.820 with float32); labels: their class indices (N), in
            ascending order (each class one contiguous slice).
        info: how it was calibrated (strings), for the record.
    """

    classes: tuple[str, ...]
    dt_s: float
    n_win: int
    q_weight_K_per_W: float
    k: int
    sigma2: float
    sigma2_rel: float
    center: np.ndarray
    basis: np.ndarray
    refs: np.ndarray
    labels: np.ndarray
    info: str = ""


def touch_vector(inp: FitInput, q_weight_K_per_W: float) -> np.ndarray:
    """[T_sensor − pre-contact mean (°C) over the window, (Q − pre-contact mean)·q_weight (°C)] (pure)."""
    n = inp.n_pre
    dT = inp.T[n:] - float(np.mean(inp.T[:n]))
    dQ = (inp.Q[n:] - float(np.mean(inp.Q[:n]))) * q_weight_K_per_W
    return np.concatenate([dT, dQ])


def project(cal: Calibration, v: np.ndarray) -> np.ndarray | None:
    """The touch vector on the calibration's components, or None when it was measured with another window."""
    if v.shape != cal.center.shape or not np.isfinite(v).all():
        return None
    return cal.basis @ (v - cal.center)


def class_residual(cal: Calibration, z: np.ndarray, c: int) -> float:
    """Squared distance (°C²) of the projected touch ``z`` to the affine span of class ``c``'s ``cal.k``
    nearest references (pure; one unit of the slave's staged classification)."""
    lo, hi = np.searchsorted(cal.labels, [c, c + 1])          # the references are ordered by class
    R = cal.refs[lo:hi]
    if R.shape[0] == 0:
        return math.inf
    d = np.einsum("ij,ij->i", R - z, R - z)
    nn = R[nearest_indices(d, cal.k)]
    m = nn.mean(axis=0)
    A = (nn - m).T
    coef = np.linalg.lstsq(A, z - m, rcond=None)[0]
    r = z - m - A @ coef
    return float(r @ r)


def nearest_indices(d: np.ndarray, k: int) -> np.ndarray:
    """Indices of the ``k`` smallest of ``d``, the same as ``np.argsort(d, kind="stable")[:k]`` (pure).

    Not np.argpartition: numpy's SIMD selection never returned on some of these inputs under the vcan VM's
    emulated CPU (the slave's cycle thread hung in it); timsort takes no SIMD path. Sorting all of a metal's
    9000 references cost 0.65 ms, so only the candidates at or below the k-th smallest of every eighth are
    sorted: that subset's k-th smallest is not below the whole set's, so all k nearest are among them, and a
    stable sort of the candidates (in index order) breaks ties as the full sort does."""
    n = d.size
    if k >= n:
        return np.argsort(d, kind="stable")
    sub = d[::8]
    cand = np.flatnonzero(d <= np.sort(sub)[k - 1]) if sub.size >= k else np.arange(n)
    return cand[np.argsort(d[cand], kind="stable")[:k]]


def by_class(refs: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """References and labels ordered by class (stable: each class keeps its own order), so that a class is one
    contiguous slice."""
    order = np.argsort(labels, kind="stable")
    return refs[order], labels[order]


def signal_size(cal: Calibration, z: np.ndarray) -> float:
    """|z − z₀|², °C²: the projected touch's squared distance to a touch without any signal."""
    d = z + cal.basis @ cal.center
    return float(d @ d)


def decide(cal: Calibration, residuals: list[float], z: np.ndarray) -> tuple[int, float]:
    """(index of the nearest class, its posterior) from the per-class residuals of the projected touch ``z``:
    softmax of −residual/(2σ²), σ² the residual's scale sigma2 + sigma2_rel·|z − z₀|² per degree of freedom
    (the m components less the k − 1 of the local model: the residual is a sum of that many squares)."""
    r = np.asarray(residuals, float)
    dof = max(cal.basis.shape[0] - (cal.k - 1), 1)
    ll = -0.5 * r * dof / (cal.sigma2 + cal.sigma2_rel * signal_size(cal, z))
    post = np.exp(ll - ll.max())
    post /= post.sum()
    i = int(np.argmin(r))
    return i, float(post[i])


def classify_vector(cal: Calibration, v: np.ndarray) -> tuple[int, float] | None:
    """All classes at once (the batch form of the slave's staged classification)."""
    z = project(cal, v)
    if z is None:
        return None
    return decide(cal, [class_residual(cal, z, c) for c in range(len(cal.classes))], z)


def whitener(noise_cov: np.ndarray, reg: float) -> np.ndarray:
    """W with W·(Σ + reg·mean(diag Σ)·I)·Wᵀ = I (pure): the touch vector's measurement noise made white.

    Σ is the covariance of the touch vector's noise (the rig's noise through its low-pass, the pre-contact mean
    and the controller's response to it); the filter leaves it nearly singular at high frequency, where the
    local models' own error would be amplified without bound, hence the floor ``reg`` (relative to the mean
    variance)."""
    S = np.asarray(noise_cov, float)
    S = 0.5 * (S + S.T) + reg * float(np.mean(np.diag(S))) * np.eye(S.shape[0])
    return np.linalg.inv(np.linalg.cholesky(S))


def build_calibration(V: np.ndarray, y: np.ndarray, classes: list[str], dt_s: float, q_weight_K_per_W: float,
                      k: int = 6, m: int = 24, info: str = "", noise_cov: np.ndarray | None = None,
                      reg: float = 0.01) -> Calibration:
    """A calibration from reference touch vectors ``V`` (N × 2·n_win, °C) and their class indices ``y``:
    principal components, the references projected; the posterior's scale from the leave-one-out residual of
    the right class over up to 600 references: σ² at zero signal the median over the fifth with the smallest
    transients, its growth the median (residual − that)/|z − z₀|² over the fifth with the largest.

    With ``noise_cov`` (the touch vector's noise covariance, °C²), distances are measured in noise units: the
    vectors are whitened (:func:`whitener`) before the principal components, and the whitening is folded into
    the stored basis (the projection stays basis·(v − center)), so the nearest references are the likeliest
    under the rig's noise rather than the nearest in °C, where the large slow components of the transient
    (object temperature, force) hide the fast ones that tell the materials apart."""
    V, y = by_class(np.asarray(V, float), np.asarray(y, int))
    center = V.mean(axis=0)
    W = whitener(noise_cov, reg) if noise_cov is not None else np.eye(V.shape[1])
    basis = np.linalg.svd((V - center) @ W.T, full_matrices=False)[2][:m] @ W
    refs = (V - center) @ basis.T
    cal = Calibration(tuple(classes), float(dt_s), V.shape[1] // 2, float(q_weight_K_per_W), int(k), 1.0, 0.0,
                      center, basis, refs, y, info)
    res, size = [], []
    for i in np.linspace(0, len(y) - 1, min(600, len(y))).astype(int):
        keep = np.arange(len(y)) != i
        loo = Calibration(cal.classes, cal.dt_s, cal.n_win, cal.q_weight_K_per_W, cal.k, 1.0, 0.0, center, basis,
                          refs[keep], y[keep])
        res.append(class_residual(loo, refs[i], int(y[i])))
        size.append(signal_size(cal, refs[i]))
    res, size = np.array(res), np.array(size)
    order = np.argsort(size)
    fifth = max(len(order) // 5, 1)
    s0 = max(float(np.median(res[order[:fifth]])), 1e-12)
    big = order[-fifth:]
    s1 = max(float(np.median(np.maximum(res[big] - s0, 0.0) / np.maximum(size[big], 1e-12))), 0.0)
    return Calibration(cal.classes, cal.dt_s, cal.n_win, cal.q_weight_K_per_W, cal.k, s0, s1, center, basis, refs,
                       y, info)


def _compact(refs: np.ndarray) -> np.ndarray:
    """The references as float16 when they fit in its range (half the file), else float32."""
    return refs.astype(np.float16) if float(np.max(np.abs(refs), initial=0.0)) < 6.0e4 else refs.astype(np.float32)


def save_calibration(cal: Calibration, path: str | Path) -> Path:
    """Write the calibration file atomically (a reader sees the old file or the new one)."""
    buf = io.BytesIO()
    np.savez_compressed(buf, format=np.array(FORMAT), classes=np.array(cal.classes),
                        dt_s=np.array(cal.dt_s), n_win=np.array(cal.n_win),
                        q_weight_K_per_W=np.array(cal.q_weight_K_per_W), k=np.array(cal.k),
                        sigma2=np.array(cal.sigma2), sigma2_rel=np.array(cal.sigma2_rel), center=cal.center, basis=cal.basis,
                        refs=_compact(cal.refs), labels=cal.labels.astype(np.int16), info=np.array(cal.info))
    return write_bytes_atomic(path, buf.getvalue())


def _field(path: Path, data, key: str, ndim: int) -> np.ndarray:
    """Field ``key`` with ``ndim`` dimensions, or ValueError naming the file and the field."""
    if key not in data.files:
        raise ValueError(f"{path}: missing field {key!r}")
    a = data[key]
    if a.ndim != ndim:
        raise ValueError(f"{path}: field {key!r}: expected {ndim} dimensions, got {a.ndim}")
    if a.dtype.kind in "fi" and not np.isfinite(a).all():
        raise ValueError(f"{path}: field {key!r}: not finite")
    return a


def _scalar(path: Path, data, key: str, lo: float, inclusive: bool = False) -> float:
    """Scalar field ``key`` > ``lo`` (≥ when ``inclusive``), or ValueError naming the file and the field."""
    a = _field(path, data, key, 0)
    if a.dtype.kind not in "fi" or not (float(a) >= lo if inclusive else float(a) > lo):
        raise ValueError(f"{path}: field {key!r}: expected a number {'≥' if inclusive else '>'} {lo:g}, got {a!r}")
    return float(a)


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
        dt, qw, s2 = (_scalar(path, data, key, 0.0) for key in ("dt_s", "q_weight_K_per_W", "sigma2"))
        s2_rel = _scalar(path, data, "sigma2_rel", 0.0, inclusive=True)
        n_win, k = int(_scalar(path, data, "n_win", 5.0)), int(_scalar(path, data, "k", 0.0))
        center, basis = _field(path, data, "center", 1), _field(path, data, "basis", 2)
        refs, labels = _field(path, data, "refs", 2), _field(path, data, "labels", 1)
        if center.shape != (2 * n_win,) or basis.shape[1] != center.size:
            raise ValueError(f"{path}: field 'center'/'basis': expected {2 * n_win} values per touch (n_win {n_win})")
        if refs.shape[1] != basis.shape[0] or refs.shape[0] != labels.size:
            raise ValueError(f"{path}: field 'refs': expected {labels.size} × {basis.shape[0]}, got {refs.shape}")
        if labels.dtype.kind != "i" or labels.size == 0 or labels.min() < 0 or labels.max() >= classes.size:
            raise ValueError(f"{path}: field 'labels': expected class indices 0..{classes.size - 1}")
        info = str(data["info"]) if "info" in data.files else ""
        refs, labels = by_class(refs.astype(float), labels.astype(int))
        return Calibration(tuple(str(c) for c in classes), dt, n_win, qw, k, s2, s2_rel, center.astype(float),
                           basis.astype(float), refs, labels, info)
