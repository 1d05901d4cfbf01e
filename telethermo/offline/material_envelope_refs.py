"""Reference touches across the operating envelope for the slave's envelope classifier (issue 23).

The in-box classifier (telethermo/data/material_classifier.npz) was trained on touches of one box (objects
15–35 °C, 2–10 N, 1–20 mm, the shipped probe at its rest in a 25 °C room) and must abstain outside it. The
envelope classifier is trained on touches drawn like the envelope bench's (objects 5–50 °C, room 15–32 °C,
force 0.5–20 N and thickness 0.3–20 mm log-uniform, noise × 1–3) on a family of probes: half the touches on
the shipped module, half on :data:`N_TEMS` other modules drawn across the envelope's probe ranges
(telethermo.offline.envelope.RANGES ``s_*``: Seebeck, resistance, conductance, I_max, plate capacity, heat
sink), each running the gains ``telethermo identify`` gives it (offline identification,
telethermo.offline.envelope.identified_params), the probe resting where its controller leaves it. So a lab's
module after ``identify`` is one more member of a family the classifier has seen, not the one it was trained
on: the bench's 71-couple module and the swap test's module are not in the family.

Seeds: :data:`ENV_REFERENCES` (draw seed, first simulator seed), :data:`TEM_FAMILY_SEED`; the development set
that chose the features and the network's size is :data:`ENV_DEVELOPMENT`. Each is disjoint from the
bench's evaluation, held-out and envelope touches (bench/material_id_envelope.py checks).
"""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from telethermo.control.types import Role
from telethermo.offline.envelope import RANGES, identified_params
from telethermo.offline.material_touches import (
    AMBIENT_C,
    PERIOD_S,
    PRE_S,
    SIM_TO_TABLE,
    envelope_conditions,
    finger_natural_C,
    noise_of,
    simulate_touch,
)
from telethermo.sim.tem import load_rig_params

#: (draw seed, first simulator seed) of the envelope classifier's reference touches and of its development set
ENV_REFERENCES, ENV_REFERENCES_N = (7171, 5_000_000), 192_000
ENV_DEVELOPMENT, ENV_DEVELOPMENT_N = (6262, 4_000_000), 3000
#: the other probe modules of the family: how many, and the seed of their draw
N_TEMS, TEM_FAMILY_SEED = 12, 8181
#: samples kept per touch: before the sample the detector calls contact, and from it on (1.3 s at 10 ms)
KEEP_PRE, KEEP_POST = 20, 130


def tem_family(n: int = N_TEMS, seed: int = TEM_FAMILY_SEED) -> list[dict[str, float]]:
    """``n`` probe modules drawn uniformly (log-uniformly where the envelope says so) over the envelope's
    probe-side ranges: their factors on the shipped module (``seebeck_x``, ``R_x``, ``K_x``, ``plate_C_x``)
    and their ``I_max_A`` and ``sink_R_K_W``."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        tem = {}
        for key in ("seebeck_x", "R_x", "K_x", "I_max_A", "plate_C_x", "sink_R_K_W"):
            lo, hi, log = RANGES[f"s_{key}"]
            u = float(rng.uniform())
            tem[key] = math.exp(math.log(lo) + u * math.log(hi / lo)) if log else lo + u * (hi - lo)
        out.append(tem)
    return out


def scaled_rig(base: Any, tem: dict[str, float]) -> Any:
    """The rig ``base`` with its module scaled by ``tem`` (:func:`tem_family`'s keys)."""
    t = dataclasses.replace(
        base.tem,
        alpha_V_K=base.tem.alpha_V_K * tem["seebeck_x"],
        R_ohm=base.tem.R_ohm * tem["R_x"],
        K_W_K=base.tem.K_W_K * tem["K_x"],
        I_max_A=tem["I_max_A"],
        plate_C_J_K=base.tem.plate_C_J_K * tem["plate_C_x"],
    )
    return base.with_(tem=t, sink_R_K_W=tem["sink_R_K_W"])


def rig_family(n: int = N_TEMS, seed: int = TEM_FAMILY_SEED) -> list[tuple[Any, Any]]:
    """(rig parameters, the slave core's parameters) of the shipped probe (its defaults) and of each module of
    the family after the offline ``identify`` in the default room (a module whose identification is refused
    is left out, as a lab could not run it either)."""
    base = load_rig_params()
    out: list[tuple[Any, Any]] = [(base, None)]
    for i, tem in enumerate(tem_family(n, seed)):
        rig = scaled_rig(base, tem)
        cp, fit = identified_params(Role.SLAVE, rig, AMBIENT_C, PERIOD_S, seed + i)
        if not fit.get("identify_refused"):
            out.append((rig, cp))
    return out


def reference_draws(n: int, seeds: tuple[int, int], n_rigs: int) -> list[dict[str, Any]]:
    """``n`` touches across the envelope (the ten materials in turn, the bench's ranges), each on rig
    ``rig`` of :func:`rig_family` (0, the shipped probe, for half of them)."""
    rng = np.random.default_rng(seeds[0])
    out = []
    for i in range(n):
        shipped = rng.uniform() < 0.5
        out.append(
            {
                "class": i % len(SIM_TO_TABLE),
                **envelope_conditions(rng),
                "rig": 0 if shipped else int(rng.integers(1, max(n_rigs, 2))),
                "t_on_s": PRE_S + float(rng.uniform(0.0, PERIOD_S)),
                "seed": seeds[1] + i,
            }
        )
    return out


def reference_touch(rigs: list[tuple[Any, Any]], d: dict[str, Any]) -> tuple[np.ndarray, np.ndarray] | None:
    """(T_sensor_C, Q_W) of touch ``d`` from :data:`KEEP_PRE` samples before the detector's contact sample to
    :data:`KEEP_POST` after (None: no contact detected in time), the slave's controller on its rig, without
    its own identification (the same current)."""
    params, core = rigs[d["rig"]]
    T, Q, i0, _, _ = simulate_touch(
        params,
        list(SIM_TO_TABLE)[d["class"]],
        d["thickness_m"],
        d["T_object_C"],
        d["force_N"],
        finger_natural_C(params, d["ambient_C"]),
        seed=d["seed"],
        t_on_s=d["t_on_s"],
        noise=noise_of(d["noise_x"]),
        ambient_C=d["ambient_C"],
        post_s=(KEEP_POST + 5) * PERIOD_S,
        identify=False,
        core_params=core,
    )
    if i0 < KEEP_PRE or i0 + KEEP_POST > T.size:
        return None
    return T[i0 - KEEP_PRE : i0 + KEEP_POST], Q[i0 - KEEP_PRE : i0 + KEEP_POST]


def _chunk(job: tuple[list[tuple[Any, Any]], list[dict[str, Any]]]) -> list[Any]:
    rigs, draws = job
    return [reference_touch(rigs, d) for d in draws]


def reference_set(
    n: int, seeds: tuple[int, int], jobs: int = 1, chunk: int = 500, progress: Any = None
) -> dict[str, np.ndarray]:
    """``n`` reference touches simulated in ``jobs`` processes (the same touches whatever ``jobs``): arrays
    ``T`` and ``Q`` (touches × KEEP_PRE + KEEP_POST; the detector's contact sample at index KEEP_PRE) and
    each touch's draw (``class``, ``T_object_C``, ...), touches without a contact left out."""
    rigs = rig_family()
    draws = reference_draws(n, seeds, len(rigs))
    parts = [(rigs, draws[i : i + chunk]) for i in range(0, n, chunk)]
    res: list[Any] = []
    with ProcessPoolExecutor(max_workers=max(jobs, 1)) as pool:
        for done in pool.map(_chunk, parts):
            res += done
            if progress is not None:
                progress(len(res), n)
    keep = [i for i, r in enumerate(res) if r is not None]
    out = {"T": np.stack([res[i][0] for i in keep]), "Q": np.stack([res[i][1] for i in keep])}
    for k in draws[0]:
        out[k] = np.array([draws[i][k] for i in keep])
    return out
