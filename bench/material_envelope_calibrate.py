"""Train the slave's envelope classifiers on simulated reference touches across the envelope (issue 23).

``python -m bench.material_envelope_calibrate [--touches 192000] [--jobs 2] [--refs CACHE.npz]``

The procedure (reference touches on the shipped probe and a family of other modules after ``identify``, the
envelope vectors, three networks: the early answer's, the one the refined answer pools with, the refined
answer's) is telethermo/offline/material_envelope_calibration.py's :func:`calibrate`; it writes
telethermo/data/material_envelope_early.npz, material_envelope_pool.npz and material_envelope_late.npz.
About 13 min of simulation in 2 processes on this machine when it is quiet, 7 min of training (192 000
touches, 60 epochs; docs/material_id.md, "More references", says why); ``--refs`` keeps the
simulated touches so that training again does not simulate again. ``--ranges-only --refs CACHE.npz`` records
the range of the references' network inputs in the shipped classifiers (their novelty check) without
training again. ``--pool-only [--dev CACHE.npz]`` fits the refined answer's pool with the pool's early
classifier (material_calib.pooled) on the development touches (material_envelope_refs.ENV_DEVELOPMENT,
3000; about a minute) and records it in the shipped refined classifier.
"""

from __future__ import annotations

import argparse
import time

from telethermo.offline.material_envelope_calibration import calibrate, record_pool, record_ranges
from telethermo.offline.material_envelope_refs import ENV_REFERENCES_N


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.material_envelope_calibrate",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument(
        "--touches", type=int, default=ENV_REFERENCES_N, help=f"reference touches ({ENV_REFERENCES_N})"
    )
    ap.add_argument("--jobs", type=int, default=2, help="simulating processes (2)")
    ap.add_argument("--refs", help="keep the simulated touches in this .npz (read it when it exists)")
    ap.add_argument(
        "--ranges-only",
        action="store_true",
        help="only record the references' input ranges in the shipped classifiers (needs --refs)",
    )
    ap.add_argument(
        "--pool-only",
        action="store_true",
        help="only fit the refined answer's pool on the development touches and record it",
    )
    ap.add_argument("--dev", help="keep the development touches in this .npz (read it when it exists)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    if args.pool_only:
        w = record_pool(args.dev, args.jobs)
        print(f"recorded the refined answer's pool: early {w[0]}, refined {w[1]}", end=" ")
        print(f"({time.perf_counter() - t0:.0f} s)")
        return 0
    if args.ranges_only:
        if not args.refs:
            ap.error("--ranges-only needs --refs (the reference touches the classifiers were trained on)")
        record_ranges(args.refs)
        print(f"recorded the references' input ranges ({time.perf_counter() - t0:.0f} s)")
        return 0
    early, partner, late = calibrate(args.touches, args.jobs, args.refs, dev=args.dev)
    print(
        f"wrote the early ({early.n_win} samples), the pool's early ({partner.n_win}) and the refined "
        f"({late.n_win}) envelope classifiers"
    )
    print(f"{time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
