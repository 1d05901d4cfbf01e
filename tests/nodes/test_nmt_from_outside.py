"""NMT commands from another master on the bus, against the live real-time pair over the hub (issue 12):
raw python-can frames (socketcand client) only, no project client code.

- NMT STOP of the SYNC producer: it stops producing SYNC (CiA 301: STOPPED = NMT and heartbeat only),
  the process lives on, and NMT START resumes the SYNC cycles (FAIL 1: the master died with exit 1).
- A slave put into PRE-OPERATIONAL: the master, NMT master of the pair, starts it again as docs/nodes.md
  says (FAIL 3: only a boot-up was answered), and the session resumes.
"""

from __future__ import annotations

import threading
from pathlib import Path

import can
import pytest

from telethermo.bus_config import path as bc
from telethermo.nodes.launch import NodePair, PairConfig, wait_for

pytestmark = pytest.mark.slow  # starts processes

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
SLOW_HEARTBEAT_MS = 1000  # the heartbeat period of the pair the `telethermo nmt` test runs against, ms


class Frames(can.Listener):
    """Every frame a raw hub client sees, as (index, COB-ID, data)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.frames: list[tuple[int, bytes]] = []

    def on_message_received(self, msg: can.Message) -> None:
        with self._lock:
            self.frames.append((msg.arbitration_id, bytes(msg.data)))

    def mark(self) -> int:
        with self._lock:
            return len(self.frames)

    def since(self, mark: int) -> list[tuple[int, bytes]]:
        with self._lock:
            return self.frames[mark:]

    def count_since(self, cob_id: int, mark: int) -> int:
        return sum(1 for cob, _ in self.since(mark) if cob == cob_id)


def _realtime_pair(tmp_path, network: Path | None = None):
    pair = NodePair(
        PairConfig(
            scene=SCENE,
            out_dir=tmp_path,
            timing="realtime",
            cycles=0,
            seed=0,
            progress_every=10,
            network=network,
        )
    )
    pair.start()
    bus = can.Bus(
        interface="socketcand", host="127.0.0.1", port=pair.hub.port, channel="telethermo", tcp_tune=True
    )
    frames = Frames()
    notifier = can.Notifier(bus, [frames], timeout=0.05)
    try:
        assert wait_for(lambda: pair.progress[0] >= 100, 120), "session did not start"
        yield pair, bus, frames
    finally:
        notifier.stop()
        bus.shutdown()
        pair.stop()


@pytest.fixture
def realtime_pair(tmp_path):
    yield from _realtime_pair(tmp_path)


def slow_heartbeat_network(tmp_path: Path) -> Path:
    """The packaged network file with heartbeats 1 s apart (consumers 3 s): a node's next heartbeat comes
    1 s after the one before, not 100 ms."""
    text = bc("network.toml").read_text(encoding="utf-8")
    for old, new in (
        ("producer_ms = 100 ", f"producer_ms = {SLOW_HEARTBEAT_MS} "),
        ("consumer_ms = 250 ", f"consumer_ms = {3 * SLOW_HEARTBEAT_MS} "),
        ('eds = "master.eds"', f'eds = "{bc("master.eds")}"'),
        ('eds = "slave.eds"', f'eds = "{bc("slave.eds")}"'),
    ):
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    net = tmp_path / "network.toml"
    net.write_text(text, encoding="utf-8")
    return net


@pytest.fixture
def slow_heartbeat_pair(tmp_path):
    net = slow_heartbeat_network(tmp_path)
    for got in _realtime_pair(tmp_path, net):
        yield (*got, net)


def _nmt(bus, command: int, node_id: int) -> None:
    bus.send(can.Message(arbitration_id=0x000, data=[command, node_id], is_extended_id=False))


def _heartbeat_state(frames: Frames, mark: int, node_id: int) -> int | None:
    states = [d[0] for cob, d in frames.since(mark) if cob == 0x700 + node_id and len(d) == 1]
    return states[-1] if states else None


def _heartbeats(frames: Frames, mark: int, node_id: int, state: int) -> int:
    """Heartbeats of ``node_id`` reporting NMT ``state`` since ``mark``: a node's own clock, 100 ms a beat."""
    return sum(1 for cob, d in frames.since(mark) if cob == 0x700 + node_id and d == bytes([state]))


def test_nmt_stop_of_the_real_time_sync_producer_pauses_it_and_start_resumes(realtime_pair):
    pair, bus, frames = realtime_pair
    _nmt(bus, 0x02, 1)  # stop the master (SYNC producer)
    mark = frames.mark()
    assert wait_for(lambda: _heartbeat_state(frames, mark, 1) == 4, 5), "no STOPPED heartbeat from the master"
    quiet = frames.mark()
    # 5 heartbeats in STOPPED: the master ran on ~50 SYNC periods (0.5 s of its own clock) meanwhile
    assert wait_for(lambda: _heartbeats(frames, quiet, 1, 4) >= 5, 10), "the master's heartbeat stopped"
    assert pair.master.poll() is None, "the master process died on NMT STOP"
    assert not [d for cob, d in frames.since(quiet) if cob == 0x080], "SYNC produced in STOPPED"
    _nmt(bus, 0x01, 1)  # start it again
    resumed = frames.mark()
    assert wait_for(lambda: sum(cob == 0x080 for cob, _ in frames.since(resumed)) >= 50, 30), (
        "SYNC did not resume"
    )
    k = pair.progress[0]
    assert wait_for(lambda: pair.progress[0] >= k + 50, 30), "the master's cycles did not resume"
    assert pair.master.poll() is None
    counters = [d[0] for cob, d in frames.since(resumed) if cob == 0x080]
    steps = {(b - a) % 240 for a, b in zip(counters, counters[1:])}
    assert steps == {1}, f"SYNC counter not continuous after the restart: {sorted(steps)}"


def test_the_master_starts_a_slave_put_into_pre_operational(realtime_pair):
    pair, bus, frames = realtime_pair
    mark = frames.mark()
    _nmt(bus, 0x80, 2)  # another NMT master puts the slave into PRE-OP
    assert wait_for(lambda: (0x000, bytes([0x01, 0x02])) in frames.since(mark), 5), (
        "the master did not start the pre-operational slave"
    )
    started = frames.mark()
    assert wait_for(lambda: _heartbeat_state(frames, started, 2) == 5, 5), (
        "the slave is not OPERATIONAL again"
    )
    # the pair goes on: the slave's TPDO1 on every SYNC again, both processes alive
    again = frames.mark()
    assert wait_for(lambda: sum(cob == 0x182 for cob, _ in frames.since(again)) >= 100, 30)
    assert pair.master.poll() is None and pair.slave.poll() is None
    starts = [d for cob, d in frames.since(mark) if cob == 0x000 and d == bytes([0x01, 0x02])]
    assert len(starts) == 1, f"{len(starts)} NMT starts for one pre-operational episode"


def test_cli_nmt_preop_slave_says_the_master_started_it_again(slow_heartbeat_pair, capsys):
    """Issue 25: `telethermo nmt preop slave` said "NOT confirmed" (and `telethermo preop:`) because the
    master starts the slave again ~2 ms after its PRE-OPERATIONAL heartbeat. The CLI saw the state; it says
    who undid it. The CLI reads the state from the slave's next heartbeat: the pair's heartbeats are 1 s
    apart so that the master's NMT start (through the hub, on a loaded machine) comes before that one (with
    100 ms, a master slower than 100 ms left the slave's next heartbeat PRE-OPERATIONAL)."""
    from telethermo.cli.main import main

    pair, bus, frames, net = slow_heartbeat_pair
    mark = frames.mark()
    code = main(["nmt", "--network", str(net), "--bus", pair.bus, "preop", "slave"])
    out, err = capsys.readouterr()
    assert code == 1, (out, err)
    assert out == "slave (node 2): OPERATIONAL\n"
    line = err.strip()
    assert "\n" not in line and line.startswith(
        "telethermo nmt: slave (node 2) reported PRE-OPERATIONAL, then "
        "OPERATIONAL: another NMT master sent NMT start "
    ), line
    assert line.endswith(
        " ms after its PRE-OPERATIONAL heartbeat (the pair's SYNC producer starts a node that "
        "reports PRE-OPERATIONAL or a boot-up: docs/nodes.md); it does not stay there"
    ), line
    # what the CLI says is on the bus: our NMT PRE-OP, the slave's PRE-OP heartbeat, the master's NMT start
    seen = frames.since(mark)
    assert (0x000, bytes([0x80, 0x02])) in seen and (0x702, bytes([0x7F])) in seen
    assert (0x000, bytes([0x01, 0x02])) in seen


def test_the_sync_producer_in_pre_operational_produces_sync_but_no_pdo(realtime_pair):
    """CiA 301: SYNC is produced in PRE-OPERATIONAL and OPERATIONAL (issue 12 deviation: the master stopped
    producing in PRE-OPERATIONAL). No control cycle and no PDO of the master until NMT start."""
    pair, bus, frames = realtime_pair
    _nmt(bus, 0x80, 1)
    mark = frames.mark()
    assert wait_for(lambda: _heartbeat_state(frames, mark, 1) == 127, 5), "no PRE-OPERATIONAL heartbeat"
    preop = frames.mark()
    assert wait_for(lambda: sum(cob == 0x080 for cob, _ in frames.since(preop)) >= 30, 30), (
        "no SYNC in PRE-OPERATIONAL"
    )
    k = pair.progress[0]
    cobs = {cob for cob, _ in frames.since(preop)}
    assert not cobs & {0x181, 0x281, 0x381, 0x481}, "a PDO of the master in PRE-OPERATIONAL"
    _nmt(bus, 0x01, 1)
    assert wait_for(lambda: pair.progress[0] >= k + 50, 30), "the master's cycles did not resume"
    counters = [d[0] for cob, d in frames.since(preop) if cob == 0x080]
    assert {(b - a) % 240 for a, b in zip(counters, counters[1:])} == {1}


@pytest.mark.parametrize("stopped", [2, 1], ids=["slave", "master"])
def test_lockstep_goes_on_while_a_node_is_stopped_and_resumes_in_step(tmp_path, stopped):
    """Lockstep: a slave stopped by another NMT master answers no SYNC, so it owes no PDO; the master goes on
    at the SYNC period (peer_lost trip, ramp, cut) and the exchange is back in step after NMT start (it stayed
    at one lockstep timeout per cycle for ever: the unanswered SYNCs were counted as owed). A stopped master
    drops the slave's PDOs: after its NMT start nothing is owed either (the same stall)."""
    pair = NodePair(
        PairConfig(scene=SCENE, out_dir=tmp_path, timing="lockstep", cycles=0, seed=0, progress_every=10)
    )
    pair.start()
    bus = can.Bus(
        interface="socketcand", host="127.0.0.1", port=pair.hub.port, channel="telethermo", tcp_tune=True
    )
    frames = Frames()
    notifier = can.Notifier(bus, [frames], timeout=0.05)
    try:
        assert wait_for(lambda: pair.progress[0] >= 100, 120), "session did not start"
        mark = frames.mark()
        _nmt(bus, 0x02, stopped)
        assert wait_for(lambda: _heartbeat_state(frames, mark, stopped) == 4, 5)
        k = pair.progress[0]
        if stopped == 2:
            assert wait_for(lambda: pair.progress[0] >= k + 50, 60), (
                "the master stalled while the slave was stopped"
            )
        else:  # the master stays STOPPED for 5 of its heartbeats (0.5 s)
            stopped_at = frames.mark()
            assert wait_for(lambda: _heartbeats(frames, stopped_at, stopped, 4) >= 5, 10)
        _nmt(bus, 0x01, stopped)
        started = frames.mark()
        assert wait_for(lambda: _heartbeat_state(frames, started, stopped) == 5, 5)
        back = frames.mark()
        assert wait_for(lambda: frames.count_since(0x182, back) >= 300, 60), (
            "the slave's PDOs did not come back"
        )
        # in step again: one slave TPDO1 per SYNC over the last stretch
        tail = frames.since(back)[-600:]
        syncs = sum(cob == 0x080 for cob, _ in tail)
        pdos = sum(cob == 0x182 for cob, _ in tail)
        assert abs(syncs - pdos) <= 2, f"{syncs} SYNCs but {pdos} slave PDOs: not in step"
        assert pair.master.poll() is None and pair.slave.poll() is None
    finally:
        notifier.stop()
        bus.shutdown()
        codes = pair.stop()
    assert codes["master"] == 0
    if stopped == 2:
        assert "no PDOs owed" in (tmp_path / "master.log").read_text()
