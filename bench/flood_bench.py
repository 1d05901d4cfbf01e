"""The flood aftermath (issue 12): 2 s floods of COB-ID 0x001 at full rate during a real-time session.

Once, after such a flood, the master's setpoint was seen climbing 27.8 -> 39.4 °C with no trip. This runs the
pair in real time over our hub (scene probe_touches_al_steel_wood, 100 Hz), a third client sending 0x001
frames as fast as it can for 2 s during each of the scene's touches (the link-loss fallback, peer trips and
resumes all get exercised), and reads the master's recording: the largest rise of its setpoint within a
stretch with no trip latched, the highest setpoint, and the peer losses; the same pair without a flood in the
same run is the baseline.

    python -m bench.flood_bench [--runs N]               # bench/results/flood.json
    python -m bench.flood_bench --wallclock [--runs N]   # rigs paced by the wall clock: flood_wallclock.json

Not a timed test: a benchmark (real time on a shared machine).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import can
import numpy as np

from bench.common import write_results
from telethermo.nodes.launch import NodePair, PairConfig, wait_for
from telethermo.recording.format import read_recording_csv
from telethermo.transport.bus import open_bus, parse_bus_string

SCENE = Path(__file__).resolve().parent.parent / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
FLOOD_COB_ID = 0x001
FLOOD_S = 2.0
#: scene times of the floods, s: 0.5 s into each touch of the scene (touches at 1, 6, 11, 16, 21, 26 s)
FLOOD_AT_S = (1.5, 6.5, 11.5, 16.5, 21.5, 26.5)
DURATION_S = 30.0
#: a rise of the setpoint with no trip larger than the quiet run's by this counts as the climb, °C
CLIMB_C = 5.0


def _flooder(pair: NodePair, at_s: tuple[float, ...], sent: list[int]) -> None:
    bus = open_bus(parse_bus_string(pair.bus))
    msg = can.Message(arbitration_id=FLOOD_COB_ID, data=bytes(8), is_extended_id=False)
    try:
        for t_scene in at_s:
            if not wait_for(lambda: pair.progress[0] >= int(t_scene / 0.01), 300, poll_s=0.005):
                return
            t0, n = time.monotonic(), 0
            while time.monotonic() - t0 < FLOOD_S:
                bus.send(msg)
                n += 1
            sent.append(n)
    finally:
        bus.shutdown()


def no_trip_rise(
    t: np.ndarray, sp: np.ndarray, state: np.ndarray, new_trips: list[str]
) -> tuple[float, float, float]:
    """The largest rise of the setpoint, °C, within a stretch where no trip is latched (safety state OK or
    LIMITING) and none is raised; with the times it starts and ends, s."""
    best, at = 0.0, (float("nan"), float("nan"))
    k0 = 0
    lo_k = 0
    for k in range(len(t)):
        if state[k] >= 2 or new_trips[k]:
            k0 = lo_k = k + 1
            continue
        if sp[k] < sp[lo_k]:
            lo_k = k
        if k >= k0 and sp[k] - sp[lo_k] > best:
            best, at = float(sp[k] - sp[lo_k]), (float(t[lo_k]), float(t[k]))
    return best, at[0], at[1]


class _WallClockPair(NodePair):
    """The pair on the scene's rigs paced by the wall clock (``--rig telethermo.sim.wallclock:probe_*``): as
    hardware, the current is held through a starved node's missing cycles."""

    def _common(self, role: str) -> list[str]:
        args = super()._common(role)
        i = args.index("--scene")
        args[i : i + 2] = ["--rig", f"telethermo.sim.wallclock:probe_{role}"]
        return args


def run_pair(folder: Path, flood_at: tuple[float, ...], *, wallclock: bool = False) -> dict[str, Any]:
    """One real-time session with floods at ``flood_at`` (scene s; empty: none); its figures."""
    pair = (_WallClockPair if wallclock else NodePair)(
        PairConfig(
            scene=SCENE,
            out_dir=folder,
            timing="realtime",
            cycles=int(DURATION_S / 0.01),
            seed=0,
            progress_every=10,
            master_args=["--wait-peer", "60"],
        )
    )
    sent: list[int] = []
    with pair:
        th = threading.Thread(target=_flooder, args=(pair, flood_at, sent), daemon=True)
        if flood_at:
            th.start()
        code = pair.wait_master(timeout_s=DURATION_S * 4 + 120)
        if flood_at:
            th.join(timeout=10)
    pair.stop()
    if code != 0:
        raise RuntimeError(f"master exit {code}; logs in {folder}")
    rec = read_recording_csv(folder / "master.csv")
    t, sp, state = rec.col("t_s"), rec.col("m_setpoint_C"), rec.col("m_safety_state")
    rise, t0, t1 = no_trip_rise(t, sp, state, rec.text("m_new_trips"))
    log = (folder / "master.log").read_text()
    peer = pair.result.peer if pair.result is not None else {}
    return {
        "floods": len(sent),
        "frames_sent_per_flood": sent,
        "setpoint_max_C": float(np.nanmax(sp)),
        "setpoint_max_after_start_C": float(np.nanmax(sp[t >= 1.0])),
        "no_trip_rise_C": rise,
        "no_trip_rise_from_s": t0,
        "no_trip_rise_to_s": t1,
        "peer_losses": peer.get("losses"),
        "peer_returns": peer.get("returns"),
        "missed_cycles": peer.get("missed_cycles"),
        "link_fallback_starts": log.count("rendering the last identified material locally"),
        "late_cycles": pair.result.late_cycles if pair.result is not None else None,
    }


def run(runs: int = 3, wallclock: bool = False) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="flood_bench_") as tmp:
        quiet = run_pair(Path(tmp) / "quiet", (), wallclock=wallclock)
        flooded = [run_pair(Path(tmp) / f"flood{i}", FLOOD_AT_S, wallclock=wallclock) for i in range(runs)]
    worst = max(r["no_trip_rise_C"] for r in flooded)
    out = {
        "runs": runs,
        "floods": sum(r["floods"] for r in flooded),
        "flood_s": FLOOD_S,
        "flood_cob_id": f"0x{FLOOD_COB_ID:03X}",
        "no_trip_rise_max_C": worst,
        "no_trip_rise_quiet_C": quiet["no_trip_rise_C"],
        "setpoint_max_flooded_C": max(r["setpoint_max_after_start_C"] for r in flooded),
        "setpoint_max_quiet_C": quiet["setpoint_max_after_start_C"],
        "climb_reproduced": worst > quiet["no_trip_rise_C"] + CLIMB_C,
        "quiet": quiet,
        "flooded": flooded,
        "rigs": "sim.wallclock (current held through missed cycles)"
        if wallclock
        else "scene (advanced per cycle)",
        "how": f"{runs} real-time sessions over the hub, scene {SCENE.stem}, a 2 s flood of 0x001 at full "
        f"rate at each of {FLOOD_AT_S} s; baseline: one session without flood in the same run",
    }
    print(
        f"{out['floods']} floods in {runs} runs: largest no-trip setpoint rise {worst:.2f} °C (quiet "
        f"{quiet['no_trip_rise_C']:.2f} °C), highest setpoint {out['setpoint_max_flooded_C']:.2f} °C (quiet "
        f"{out['setpoint_max_quiet_C']:.2f} °C); peer losses {[r['peer_losses'] for r in flooded]}, "
        f"link-loss fallbacks {[r['link_fallback_starts'] for r in flooded]}"
    )
    print(f"wrote {write_results('flood_wallclock' if wallclock else 'flood', out)}")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.flood_bench", description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="flooded sessions (default 3)")
    ap.add_argument(
        "--wallclock", action="store_true", help="rigs paced by the wall clock (flood_wallclock.json)"
    )
    args = ap.parse_args(argv)
    run(args.runs, args.wallclock)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
