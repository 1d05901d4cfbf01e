"""The node programs' hardware path (``--rig MODULE:FACTORY``, real time), exercised with a simulated plant
paced
by the wall clock (sim.wallclock: a ``telethermo.rig.Rig`` with no ``advance``): what a lab checks on a bench.

Both programs run as OS processes over our socketcand hub, with ``--rig sim.wallclock:pads_in_air_master`` /
``pads_in_air_slave`` (no ``--timing``: a rig without ``advance`` runs in real time, SYNC at the packaged
network's 10 ms). A third client of the hub is the bench's bus analyser: it timestamps every frame (the hub
stamps each frame when it reads it) and decodes SYNC, EMCY and TPDO2 (T_sensor_C, current_A every 10 SYNCs).

Wall-clock *speed* is never asserted: the machine is shared. What is asserted is what the schedule guarantees
(SYNC k is never sent before t0 + k·period, and, without overruns, the schedule does not drift by more than
the lateness the producer itself measured) and what it counts (late cycles are counted, not failed).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import re
import struct
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from telethermo.control.types import Role
from telethermo.nodes.launch import HubProcess, node_command, stop_process, wait_for
from telethermo.nodes.options import OptionError, build_parser, options_from_args
from telethermo.nodes.parts import _hardware_rig
from telethermo.cli.main import EXIT_FAIL, EXIT_OK
from telethermo.transport.bus import FrameLog
from telethermo.recording.merge import merge_recordings
from tests.nodes.exchange_check import check_exchange

pytestmark = pytest.mark.slow

PERIOD_S = 0.010  # the packaged bus_config/network.toml [sync] period_s
CYCLES = 300  # 3 s of real time
AMBIENT_C = 25.0  # scene pads_in_air
REST_TOL_C = 0.25  # pads at rest: noise (σ 0.02 °C, filtered) and ADC steps, far below this
SETTLED_C = 0.15  # the rendering master's pad at its pre-set: noise and a settled PI, well below this
HUB_GRACE_CYCLES = (
    25  # the hub holds a new client's first 0.2 s of frames (docs/nodes.md): 20 cycles + margin
)
RIG = {
    "master": "telethermo.sim.wallclock:pads_in_air_master",
    "slave": "telethermo.sim.wallclock:pads_in_air_slave",
}
NODE_ID = {"master": 1, "slave": 2}


class BusWitness(FrameLog):
    """A bench analyser on the hub: every frame with the hub's timestamp, in the hub's order."""

    def saw(self, can_id: int) -> bool:
        return any(f[1] == can_id for f in self.snapshot())

    def saw_the_session_end(self) -> bool:
        """The master's end of session (NMT enter pre-operational, all nodes) and every slave TPDO1 (the
        slave answers SYNC k when it gets to it: its last may follow the master's end on the bus)."""
        frames = self.snapshot()
        slave_tpdo1 = sum(1 for f in frames if f[1] == 0x180 + NODE_ID["slave"])
        return slave_tpdo1 >= CYCLES and any(f[1] == 0x000 and f[2][:1] == b"\x80" for f in frames)


def _logs(out: Path, role: str) -> str:
    return "".join(
        p.read_text(errors="replace") for p in (out / f"{role}.log", out / f"{role}-stderr.log") if p.exists()
    )


def _read_recording(path: Path) -> tuple[dict, list[dict]]:
    lines = path.read_text().splitlines()
    meta = json.loads(next(ln for ln in lines if ln.startswith("# meta "))[len("# meta ") :])
    rows = list(csv.DictReader(ln for ln in lines if not ln.startswith("#")))
    return meta, rows


def _start_node(role: str, bus: str, out: Path, *args: str, stdout=subprocess.DEVNULL) -> subprocess.Popen:
    return subprocess.Popen(
        node_command(role, "--bus", bus, "--rig", RIG[role], "--log", str(out / f"{role}.log"), *args),
        stdout=stdout,
        stderr=open(out / f"{role}-stderr.log", "ab"),
        text=True,
        start_new_session=True,
    )


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """Run 1: the pair in idle, real time, the master for CYCLES cycles, both recording; a witness on the
    bus."""
    out = tmp_path_factory.mktemp("rig_path")
    hub = HubProcess(idle_timeout_s=60, log_path=out / "hub.log")
    hub.start()
    witness = BusWitness(hub.bus)
    slave = master = None
    try:
        slave = _start_node("slave", hub.bus, out, "--mode", "idle", "--record", str(out / "slave.csv"))
        # the slave is up (its boot-up / heartbeat on the bus) before the master starts its session
        assert wait_for(lambda: witness.saw(0x700 + NODE_ID["slave"]), 60), _logs(out, "slave")
        t0 = time.monotonic()
        master = _start_node(
            "master",
            hub.bus,
            out,
            "--mode",
            "idle",
            "--cycles",
            str(CYCLES),
            "--json",
            "--record",
            str(out / "master.csv"),
            stdout=subprocess.PIPE,
        )
        stdout, _ = master.communicate(timeout=120)
        wall_total = time.monotonic() - t0
        wait_for(witness.saw_the_session_end, 10)  # the last frames reach the witness (the tests assert them)
        slave_code = stop_process(slave)
    finally:
        stop_process(master)
        stop_process(slave)
        witness.close()
        hub.stop()
    results = [json.loads(ln[len("result ") :]) for ln in stdout.splitlines() if ln.startswith("result ")]
    return {
        "out": out,
        "master_code": master.returncode,
        "slave_code": slave_code,
        "stdout": stdout,
        "result": results[0] if results else None,
        "frames": witness.snapshot(),
        "wall_total_s": wall_total,
    }


def _session_frames(bench) -> list[tuple[float, int, bytes]]:
    """The witness's frames up to the master's end of session (NMT enter pre-operational, all nodes)."""
    frames = bench["frames"]
    end = next((i for i, f in enumerate(frames) if f[1] == 0x000 and f[2][:1] == b"\x80"), len(frames))
    return frames[:end]


def _expected_mean_step_bounds(
    result: dict, n_steps: int, jitter_s: float = 0.05
) -> tuple[float, float | None]:
    """Bounds on the mean step of n_steps SYNC intervals the producer's schedule guarantees: never faster
    than the
    period (SYNC k is not sent before t0 + k·period) and, without overruns (no re-anchoring), not slower than
    the
    lateness the producer measured spread over the run; ``jitter_s`` allows for the stamping at either end
    (hub read, rig read). With overruns only the lower bound holds (None)."""
    slack = (result["lateness_ms_max"] * 1e-3 + jitter_s) / n_steps
    upper = PERIOD_S + slack if result["overruns"] == 0 else None
    return PERIOD_S - jitter_s / n_steps, upper


def test_master_runs_its_cycles_in_real_time(bench):
    r = bench["result"]
    assert r is not None, bench["stdout"] + _logs(bench["out"], "master")
    print(
        "\nrun 1 (idle, real time):",
        json.dumps(
            {
                k: r[k]
                for k in (
                    "cycles",
                    "wall_s",
                    "late_cycles",
                    "overruns",
                    "lateness_ms_p50",
                    "lateness_ms_p99",
                    "lateness_ms_max",
                    "sync_to_tpdo_ms_p50",
                    "sync_to_tpdo_ms_p99",
                    "cycle_ms_p50",
                    "cycle_ms_p99",
                    "peer",
                )
            }
        ),
    )
    assert r["cycles"] == CYCLES and r["timing"] == "realtime" and r["period_s"] == PERIOD_S
    assert r["lockstep_timeouts"] == 0
    assert f"SYNC producer: {CYCLES} of {CYCLES} cycles run" in _logs(bench["out"], "master")
    # late cycles are counted (0x2703, the result), never hidden, never failed: a late cycle is one more than
    # half a period late, an overrun (re-anchoring) one a whole period late
    assert 0 <= r["overruns"] <= r["late_cycles"] <= CYCLES
    assert (r["late_cycles"] > 0) == (r["lateness_ms_max"] > 0.5 * PERIOD_S * 1e3)
    # the schedule never ran faster than the period: CYCLES SYNCs take at least (CYCLES - 1) periods
    assert r["wall_s"] >= (CYCLES - 1) * PERIOD_S


def test_sync_period_on_the_bus_is_10_ms(bench):
    """Every SYNC on the bus, its counter in sequence, and the mean SYNC period from the hub's timestamps
    within
    the bounds the producer's schedule guarantees (no wall-clock speed assertion beyond its own lateness)."""
    r = bench["result"]
    syncs = [f for f in _session_frames(bench) if f[1] == 0x080]
    assert len(syncs) == CYCLES
    counters = [f[2][0] for f in syncs]
    assert counters[0] == 1 and all(b == a % 240 + 1 for a, b in zip(counters, counters[1:]))  # none lost
    t = np.array([f[0] for f in syncs])
    steps = np.diff(t)
    mean = float(steps.mean())
    lo, hi = _expected_mean_step_bounds(r, len(steps))
    print(
        f"\nSYNC on the bus: mean {mean * 1e3:.4f} ms, median {np.median(steps) * 1e3:.3f} ms, "
        f"p1..p99 {np.percentile(steps, 1) * 1e3:.2f}..{np.percentile(steps, 99) * 1e3:.2f} ms, "
        f"late cycles {r['late_cycles']}, overruns {r['overruns']}"
    )
    # the schedule's own guarantee: never faster than the period (how much slower depends on the machine's
    # load and is reported by the late-cycle count, not failed)
    assert mean >= lo
    if hi is not None:
        assert mean <= hi


def test_both_nodes_saw_the_peer(bench):
    """No EMCY during the session (a peer-loss trip would raise 0x8130), the slave never lost the master, and
    the
    master had the slave's PDOs for every cycle but the first ones (the master in idle does not await its
    peer,
    and the hub holds a newly connected client's first 0.2 s of frames), with any start-up miss over by the
    end.
    Every SYNC was answered by both nodes' TPDO1."""
    frames = _session_frames(bench)
    emcy = [f for f in frames if f[1] in (0x080 + NODE_ID["master"], 0x080 + NODE_ID["slave"])]
    # on a loaded machine a peer's PDOs may come later than the miss limit (real time): a peer-loss EMCY
    # (0x8130) and its reset (0x0000) are then the envelope working; nothing else may be raised
    assert all(int.from_bytes(f[2][:2], "little") in (0x8130, 0x0000) for f in emcy), emcy
    assert sum(1 for f in frames if f[1] == 0x180 + NODE_ID["master"]) == CYCLES
    # the slave answers SYNC k when it gets to it: its last TPDO1 may follow the master's end of session on
    # the bus
    assert sum(1 for f in bench["frames"] if f[1] == 0x180 + NODE_ID["slave"]) == CYCLES
    peer = bench["result"]["peer"]
    assert peer["non_finite"] == 0
    # real time does not wait for the peer (lockstep does): a loaded machine delivers some PDOs a cycle
    # late, two in one cycle, or after the master's last cycle, so the count of PDOs in time is reported,
    # not asserted (it was 215 of 274 with the machine three times oversubscribed). What holds: every value
    # either node used is one its peer sent at an earlier SYNC, in order, and one older than the miss limit
    # only with a peer-loss trip (docs/nodes.md, "Lockstep and real time")
    assert 0 < peer["pdos"] <= CYCLES
    merged = merge_recordings(bench["out"] / "master.csv", bench["out"] / "slave.csv")
    for me, other in (("m", "s"), ("s", "m")):
        ex = check_exchange(
            merged.col(f"{me}_peer_estimate_C"),
            merged.col(f"{other}_estimate_C").astype(np.float32),
            merged.text(f"{me}_new_trips"),
        )
        print(
            f"\n{me}: peer values {ex.fresh} of {ex.rows} the previous SYNC's, "
            f"oldest {ex.staleness_max} behind"
        )
        assert ex.rows >= len(merged) // 2, ex  # before: the hub's grace and the first PDO (load-dependent)
        assert not ex.unmatched and not ex.stale_untripped, ex
    assert peer["losses"] - peer["returns"] in (0, 1)  # every loss but possibly one at the very end resumed
    slave_log = _logs(bench["out"], "slave")
    m = re.search(
        r"stopped \(SIGTERM\): (\d+) cycles.*pdos=(\d+), missed_cycles=(\d+), losses=(\d+)", slave_log
    )
    assert m, slave_log[-3000:]
    cycles, pdos, missed, losses = map(int, m.groups())
    print(f"\nslave: {cycles} cycles, peer PDOs {pdos}, missed {missed}, losses {losses}; master peer {peer}")
    assert cycles == CYCLES and pdos + missed == CYCLES - 1
    # the session ends with the master's NMT enter pre-operational; its heartbeat stops a moment later, which
    # the
    # slave may or may not report before its own SIGTERM: only a loss during the session counts. On an idle
    # machine there is none (missed 0); a loaded one may delay PDOs past the miss limit: every such loss
    # resumed
    session, _, _ = slave_log.partition("-> PRE_OPERATIONAL (command 0x80)")
    if missed == 0 and not emcy:
        assert "lost" not in session, session[-3000:]
        assert "peer_lost" not in slave_log and "peer_lost" not in _logs(bench["out"], "master")
    else:
        assert session.count("peer values back") >= session.count("trip peer_lost"), session[-3000:]


def test_pads_at_rest_stay_at_ambient_in_idle(bench):
    """TPDO2 of both nodes on the bus (T_sensor_C, current_A every 10 SYNCs): no current, the pads at
    ambient."""
    for role in ("master", "slave"):
        vals = [struct.unpack("<ff", f[2]) for f in bench["frames"] if f[1] == 0x280 + NODE_ID[role]]
        assert len(vals) >= CYCLES // 10 - 1, role
        T = np.array([v[0] for v in vals])
        I = np.array([v[1] for v in vals])
        print(
            f"\n{role}: T_sensor {T.min():.4f}..{T.max():.4f} °C over {len(T)} TPDO2, |I| max "
            f"{np.abs(I).max()} A"
        )
        assert np.all(I == 0.0), role
        assert np.all(np.abs(T - AMBIENT_C) < REST_TOL_C), role


def test_master_and_slave_exit_0(bench):
    """The master exits 0 after its cycles, the slave 0 on SIGTERM."""
    codes = bench["master_code"], bench["slave_code"]
    assert codes == (0, 0), _logs(bench["out"], "master")[-3000:]


def test_recordings(bench):
    """Both recordings: one row per cycle, t_s (the rig's own clock) stepping 10 ms on average within the
    schedule's bounds, the pads at ambient with no current, the peer's values received."""
    out, r = bench["out"], bench["result"]
    recs = {role: _read_recording(out / f"{role}.csv") for role in ("master", "slave")}
    for role, (meta, rows) in recs.items():
        p = role[0]
        assert meta["rig"] == RIG[role] and meta["timing"] == "realtime" and meta["mode"] == "idle"
        assert len(rows) == CYCLES, role
        t = np.array([float(x["t_s"]) for x in rows])
        assert t[0] == 0.0 and np.all(np.diff(t) > 0), role
        mean = float(np.diff(t).mean())
        lo, hi = _expected_mean_step_bounds(r, CYCLES - 1)
        print(f"\n{role} recording: {len(rows)} rows, t_s mean step {mean * 1e3:.4f} ms")
        assert mean >= lo, role
        assert mean <= (hi if hi is not None else 2 * PERIOD_S), role
        # about the expected number of rows for the wall time: the rig's clock spans the session
        assert t[-1] <= bench["wall_total_s"]
        T = np.array([float(x[f"{p}_T_sensor_C"]) for x in rows])
        I = np.array([float(x[f"{p}_current_A"]) for x in rows])
        assert np.all(I == 0.0) and np.all(np.abs(T - AMBIENT_C) < REST_TOL_C), role
        assert not any("peer_lost" in x[f"{p}_new_trips"] for x in rows), role
        peer = np.array([float(x[f"{p}_peer_estimate_C"]) for x in rows[HUB_GRACE_CYCLES:]])
        assert np.all(np.abs(peer - AMBIENT_C) < REST_TOL_C), role


@pytest.mark.parametrize("role", ["master", "slave"])
def test_lockstep_is_refused_with_a_hardware_rig(role, tmp_path):
    """A hardware rig cannot advance on request: --timing lockstep with --rig is a usage error (exit 2),
    named."""
    p = subprocess.run(
        node_command(role, "--bus", "virtual:tt-rig-refused", "--rig", RIG[role], "--timing", "lockstep"),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert p.returncode == 2, p.stderr
    assert f"telethermo-{role}: error: --timing lockstep" in p.stderr and "real time" in p.stderr, p.stderr
    assert "Traceback" not in p.stderr


@pytest.mark.parametrize(
    "factory, expected",
    [
        (
            "tests.nodes.rig_factories:wrong_period",
            "period_s = 0.02 s but the network's SYNC period is 0.01 s",
        ),
        (
            "tests.nodes.rig_factories:no_device",
            "the rig factory failed: OSError: no thermal display on /dev/ttyUSB9",
        ),
        (
            "tests.nodes.rig_factories:not_a_rig",
            "not a telethermo.rig.Rig (missing read, apply_current, period_s, I_max_A)",
        ),
    ],
)
def test_a_bad_hardware_rig_is_a_named_usage_error(factory, expected, tmp_path):
    """A driver that fails, returns something else, or runs at another period than the bus: exit 2, one
    line."""
    root = Path(__file__).resolve().parents[2]
    env = dict(__import__("os").environ, PYTHONPATH=str(root))
    p = subprocess.run(
        node_command("master", "--bus", "virtual:tt-rig-bad", "--rig", factory),
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
        cwd=root,
    )
    assert p.returncode == 2, p.stderr
    assert expected in p.stderr and "Traceback" not in p.stderr, p.stderr


def parse_options(role: Role, argv: list[str]):
    """The node program's own command line (build_parser + options_from_args), as its main parses it."""
    return options_from_args(role, build_parser(role).parse_args(argv))


def test_rig_config_gives_the_driver_its_settings(tmp_path):
    """``--rig-config FILE.toml``: its top-level keys are the factory's keyword arguments (a port, a gain);
    a file that is not TOML, or settings the driver refuses, are one named line (exit 2)."""
    good = tmp_path / "rig.toml"
    good.write_text('port = "/dev/ttyTT0"\ngain = 2.5\n')
    opts = parse_options(
        Role.MASTER,
        [
            "--bus",
            "virtual:tt-rigcfg",
            "--rig",
            "tests.nodes.rig_factories:configured",
            "--rig-config",
            str(good),
        ],
    )
    rig = _hardware_rig(opts, 0.01)
    assert rig.gain == 2.5 and rig.period_s == 0.01
    wrong = tmp_path / "wrong.toml"
    wrong.write_text('port = "/dev/ttyUSB9"\n')
    with pytest.raises(
        OptionError, match="the rig factory failed: OSError: no thermal display on /dev/ttyUSB9"
    ):
        _hardware_rig(dataclasses.replace(opts, rig_config=wrong), 0.01)
    broken = tmp_path / "broken.toml"
    broken.write_text("port = \n")
    with pytest.raises(OptionError, match=r"--rig-config .*broken.toml: line \d+: not valid TOML"):
        _hardware_rig(dataclasses.replace(opts, rig_config=broken), 0.01)
    with pytest.raises(OptionError, match="only with --rig"):
        parse_options(Role.MASTER, ["--scene", "sim/scenes/pads_in_air.toml", "--rig-config", str(good)])


# The experiment of `telethermo identify master` here: 650 samples, 6.5 s of real time. Orders 2,2,0,0 fitted
# by
# least squares: stable in 30 of 30 offline experiments of this size (PRBS seeds 0..29). The first-order model
# (1,1,0,0) cannot hold the pad's fast and slow modes at once; its one pole lands on either side of the unit
# circle
# (offline 3 of 10 seeds stable; live 2 of 5 runs, the others refused with |z| = 1.012..1.026).
IDENT = {"rest": 50, "train": 400, "validation": 200, "hold": 5, "orders": "2,2,0,0", "method": "ls"}


def _ident_stream(frames, node_id: int, total: int):
    """The identification samples on the bus, decoded as ``telethermo identify`` decodes them: TPDO2, TPDO3
    and
    TPDO4, each (sample number 1..total, value): T_sensor_C, current_A, Q_W. Frames of the EDS mappings
    (before
    and after the experiment) are told apart by the sample number's range, as the CLI does; TPDO4's EDS
    mapping
    starts with the cycle counter, so only the frames between the first and the last numbered TPDO2 count.
    Returns T, I, Q and how often each sample number was seen with all three values."""
    vals = np.full((3, total), np.nan)
    got = np.zeros((3, total), dtype=int)
    cobs = {0x280 + node_id: 0, 0x380 + node_id: 1, 0x480 + node_id: 2}
    numbered = [
        n
        for n, (_, cid, data) in enumerate(frames)
        if cid == 0x280 + node_id and len(data) == 8 and 1 <= struct.unpack("<I", data[:4])[0] <= total
    ]
    if not numbered:
        return vals[0], vals[1], vals[2], np.zeros(total, dtype=int)
    for _, cid, data in frames[numbered[0] : numbered[-1] + 4]:
        f = cobs.get(cid)
        if f is None or len(data) != 8:
            continue
        k, v = struct.unpack("<If", data)
        if 1 <= k <= total:
            vals[f, k - 1] = v
            got[f, k - 1] += 1
    return vals[0], vals[1], vals[2], got.min(axis=0)


def _refit(T, I, Q) -> dict:
    """The identification fit (telethermo.ident.experiment.fit_experiment, as `telethermo identify NODE`
    calls it,
    with the CLI's default plan seed 0 and amplitudes 0.1..1 A) of samples taken from the bus: its report
    ('stable', 'max_pole_modulus', ...)."""
    from telethermo.ident import NarmaOrders, UnstableModelError
    from telethermo.ident.experiment import ExperimentSettings, Record, fit_experiment
    from telethermo.ident.plan import IdentifyPlan

    plan = IdentifyPlan(
        seed=0,
        rest_samples=IDENT["rest"],
        train_samples=IDENT["train"],
        validation_samples=IDENT["validation"],
        amplitude_A=(0.1, 1.0),
        hold_samples=IDENT["hold"],
    )
    n = plan.total
    rec = Record(
        t_s=np.arange(n) * PERIOD_S,
        current_A=I.copy(),
        T_C=T.copy(),
        Q_W=Q.copy(),
        T_sink_C=np.full(n, np.nan),
        Q_true_W=np.full(n, np.nan),
    )
    try:
        _, rep = fit_experiment(
            rec,
            plan=plan,
            orders=NarmaOrders.parse(IDENT["orders"]),
            period_s=PERIOD_S,
            method=IDENT["method"],
            settings=ExperimentSettings(
                rest_samples=plan.rest_samples, amplitude_A=plan.amplitude_A, hold_samples=plan.hold_samples
            ),
        )
    except UnstableModelError as exc:
        return {"stable": False, "max_pole_modulus": None, "stability_reason": str(exc)}
    return rep


def _cli(capsys, *argv: str) -> tuple[int, str, str]:
    from telethermo.cli.main import main

    code = main(list(argv))
    o = capsys.readouterr()
    return code, o.out, o.err


def _get(capsys, bus: str, node: str, *names: str) -> dict[str, float]:
    code, out, err = _cli(capsys, "get", "--bus", bus, node, *names)
    assert code == EXIT_OK, err
    # "master 0x2000 T_sensor_C = 25.1 degC    (...)": node, object, name, value
    return {m.group(1): float(m.group(2)) for m in re.finditer(r"^\w+ 0x[0-9A-F:]+ (\w+) = (\S+)", out, re.M)}


def test_operator_cli_against_the_real_time_pair(tmp_path, capsys):
    """Run 2: the pair in idle until stopped; the operator's CLI in process. `telethermo identify master`
    records every sample of a 650-sample experiment over the real-time stream; then `telethermo mode render
    wood`
    and the master's pad goes to the rendering pre-set temperature."""
    hub = HubProcess(idle_timeout_s=60, log_path=tmp_path / "hub.log")
    hub.start()
    bus = hub.bus
    slave = master = None
    notes: list[str] = []  # printed at the end (the CLI runs read the captured output in between)
    witness = BusWitness(bus)
    try:
        slave = _start_node("slave", bus, tmp_path, "--mode", "idle")
        master = _start_node("master", bus, tmp_path, "--mode", "idle", "--cycles", "0")

        def both_operational() -> bool:
            code, out, _ = _cli(capsys, "status", "--bus", bus, "--json", "--timeout", "1")
            return code == EXIT_OK and all(n["nmt_state"] == "OPERATIONAL" for n in json.loads(out)["nodes"])

        assert wait_for(both_operational, 60), _logs(tmp_path, "master") + _logs(tmp_path, "slave")
        code, out, err = _cli(capsys, "status", "--bus", bus, "--json")
        assert code == EXIT_OK, err
        st = {n["role"]: n["values"] for n in json.loads(out)["nodes"]}
        for role, v in st.items():
            assert v["lockstep"] is False and v["mode"] == 0 and v["peer_alive"] is True, (role, v)
            assert abs(v["T_sensor_C"] - AMBIENT_C) < REST_TOL_C and v["current_A"] == 0.0, (role, v)

        # identification in real time: 50 rest + 400 training + 200 held-out samples at 10 ms
        data = tmp_path / "ident.csv"
        t0 = time.monotonic()
        code, out, err = _cli(
            capsys,
            "identify",
            "master",
            "--bus",
            bus,
            "--no-load",
            "--samples",
            str(IDENT["train"]),
            "--validation",
            str(IDENT["validation"]),
            "--rest",
            str(IDENT["rest"]),
            "--orders",
            IDENT["orders"],
            "--method",
            IDENT["method"],
            "--hold",
            str(IDENT["hold"]),
            "--quiet",
            "--save-data",
            str(data),
        )
        t_ident = time.monotonic() - t0
        notes.append(f"identify master in real time: exit {code}, {t_ident:.1f} s\n{out}{err}")
        # the stream on the bus, as the bench analyser saw it: every sample number exactly once
        total = IDENT["rest"] + IDENT["train"] + IDENT["validation"]
        # the witness is a second reader on the hub: the CLI may finish on the last sample before the
        # witness's
        # reader thread has taken it in, so wait (on the condition) until the witness holds the whole stream
        wait_for(
            lambda: bool(np.all(_ident_stream(witness.snapshot(), NODE_ID["master"], total)[3] >= 1)), 10
        )
        T, I, Q, seen = _ident_stream(witness.snapshot(), NODE_ID["master"], total)
        assert np.all(seen == 1), f"samples not on the bus once: {np.flatnonzero(seen != 1)[:20]}"
        assert "missing" not in err and "lost on the bus" not in err  # the CLI had them all from the stream
        assert (
            np.abs(I).max() > 0.09 and np.all(np.isfinite(T)) and np.all(np.isfinite(Q))
        )  # the PRBS drove it
        # the fit of exactly those samples, done here: the CLI's verdict must be the fit's, not the stream's
        refit = _refit(T, I, Q)
        notes.append(
            f"refit of the bus samples: stable {refit['stable']}, max local pole "
            f"{refit['max_pole_modulus']}, {refit.get('stability_reason')}"
        )
        if code == EXIT_OK:
            assert refit["stable"] and "master: model not loaded (--no-load)" in out, (refit, out)
            assert f"max local pole |z| = {refit['max_pole_modulus']:.6f}" in out
            rows = [ln for ln in data.read_text().splitlines() if ln and not ln.startswith("#")]
            head = rows[0].split(",")
            saved = {
                c: np.array([float(ln.split(",")[head.index(c)]) for ln in rows[1:]])
                for c in ("T_sensor_C", "current_A", "Q_W")
            }
            assert len(saved["T_sensor_C"]) == total
            np.testing.assert_array_equal(
                saved["T_sensor_C"], T
            )  # what the CLI recorded is the stream, in order
            np.testing.assert_array_equal(saved["current_A"], I)
            np.testing.assert_array_equal(saved["Q_W"], Q)
        else:
            # a small model of a short experiment may be refused (see IDENT): acceptable only as the fit's
            # verdict
            # on a complete stream, which the refit of the bus samples above reproduces
            assert code == EXIT_FAIL and "refused" in err and "fitting" in err, (code, out, err)
            assert not refit["stable"], refit
        assert _get(capsys, bus, "master", "mode")["mode"] == 0.0  # put back in idle

        # virtual rendering of wood on the master: the pad goes to the pre-set temperature (yamamoto eq. 5/7)
        before = _get(capsys, bus, "master", "T_sensor_C")["T_sensor_C"]
        code, out, err = _cli(capsys, "mode", "--bus", bus, "render", "wood")
        assert code == EXIT_OK and "master (node 1): mode render" in out, err
        first = _get(capsys, bus, "master", "T_sensor_C", "T_cmd_C", "mode")
        assert first["mode"] == 2.0
        trace = [(-1.0, before, math.nan), (0.0, first["T_sensor_C"], first["T_cmd_C"])]
        t0 = time.monotonic()

        def settled() -> bool:
            """Three readings in a row (~1 s) of the pad at the command, the command (ramp-limited) at rest:
            past
            the render controller's overshoot (~0.4 °C, ~1 s after the switch, here)."""
            v = _get(capsys, bus, "master", "T_sensor_C", "T_cmd_C")
            trace.append((time.monotonic() - t0, v["T_sensor_C"], v["T_cmd_C"]))
            last = trace[-3:]
            return len(trace) >= 5 and all(
                abs(pad - cmd) < SETTLED_C and abs(cmd - last[-1][2]) < 1e-3 for _, pad, cmd in last
            )

        ok = wait_for(settled, 15, poll_s=0.2)
        notes.append(
            f"render wood: (s, T_sensor_C, T_cmd_C) {[tuple(round(x, 3) for x in p) for p in trace]}"
        )
        assert ok, trace
        target = trace[-1][2]  # the rendering pre-set temperature (yamamoto eq. 5/7)
        assert abs(target - AMBIENT_C) > 1.0  # away from the pad's rest: the pad had to move
        # ... from where the identification left it (its PRBS keeps the pad within ~2 °C of ambient)
        assert abs(before - target) > 0.5, trace
        dist = [abs(p[1] - target) for p in trace]
        assert (
            dist[-1] < SETTLED_C and dist[-1] < dist[0] - 0.3
        )  # it moved towards the pre-set and reached it
        held = []
        for _ in range(4):  # ... and holds it (no contact: the pre-set stays)
            # a fixed pace on purpose: samples of a real-time rig spread over 1 s (an absence check, "it
            # does not drift", on the node programs' wall clock, which the test cannot drive)
            time.sleep(0.25)
            v = _get(capsys, bus, "master", "T_sensor_C", "T_cmd_C")
            held.append((round(v["T_sensor_C"], 3), round(v["T_cmd_C"], 3)))
        notes.append(f"render wood, held: {held}")
        assert all(abs(pad - target) < SETTLED_C and abs(cmd - target) < 1e-3 for pad, cmd in held), held
        codes = {"master": stop_process(master), "slave": stop_process(slave)}
        assert codes == {"master": 0, "slave": 0}, codes
    finally:
        stop_process(master)
        stop_process(slave)
        witness.close()
        hub.stop()
        print("\n" + "\n".join(notes))


def test_rig_arg_sets_one_driver_setting_over_the_config_file(tmp_path):
    """``--rig-arg KEY=VALUE`` (repeatable): VALUE read as TOML (a number stays a number) or else text,
    over the file's keys; a malformed one, or one without --rig, is one named line."""
    cfg = tmp_path / "rig.toml"
    cfg.write_text('port = "/dev/ttyUSB9"\ngain = 2.5\n')
    opts = parse_options(
        Role.MASTER,
        [
            "--bus",
            "virtual:tt-rigarg",
            "--rig",
            "tests.nodes.rig_factories:configured",
            "--rig-config",
            str(cfg),
            "--rig-arg",
            "port=/dev/ttyTT0",
            "--rig-arg",
            "gain=4",
        ],
    )
    assert dict(opts.rig_args) == {"port": "/dev/ttyTT0", "gain": 4}
    rig = _hardware_rig(opts, 0.01)
    assert rig.gain == 4 and isinstance(rig.gain, int)
    quoted = parse_options(
        Role.MASTER,
        [
            "--bus",
            "virtual:tt-rigarg",
            "--rig",
            "tests.nodes.rig_factories:configured",
            "--rig-arg",
            'port="/dev/ttyTT0"',
            "--rig-arg",
            "gain=0.5",
        ],
    )
    assert _hardware_rig(quoted, 0.01).gain == 0.5
    with pytest.raises(OptionError, match=r"--rig-arg 'gain': expected KEY=VALUE"):
        parse_options(Role.MASTER, ["--rig", "tests.nodes.rig_factories:configured", "--rig-arg", "gain"])
    with pytest.raises(OptionError, match="only with --rig"):
        parse_options(Role.MASTER, ["--scene", "sim/scenes/pads_in_air.toml", "--rig-arg", "gain=1"])
