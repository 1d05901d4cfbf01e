"""A live pair of node programs over the loopback hub, seen through an independent client: canopen's
RemoteNode (SdoClient, NmtMaster, EMCY consumer) built from the shipped EDS files, and raw python-can
frames. No project client code: ``nodes.launch`` only starts the processes (the real console programs).

    with live_pair(out_dir, timing="realtime") as lab:
        lab.sdo(1)[0x1001].raw; lab.nmt(0x02, 2); lab.wait_heartbeat(2, 4, since=mark)

Used by the conformance checks (tests/conformance/checks.py), their tests (tests/conformance/) and
``python -m bench.conformance_bench``.
"""

from __future__ import annotations

import configparser
import contextlib
import threading
import time
from pathlib import Path
from typing import Callable, Iterator

import can
import canopen

from telethermo.bus_config import path as bus_config_path
from telethermo.nodes.launch import NodePair, PairConfig

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
MASTER, SLAVE = 1, 2
ROLE = {MASTER: "master", SLAVE: "slave"}


class Frames(can.Listener):
    """Every frame the client sees, in bus order, as (receive time, COB-ID, data)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._frames: list[tuple[float, int, bytes]] = []

    def on_message_received(self, msg: can.Message) -> None:
        if msg.is_error_frame:
            return
        with self._lock:
            self._frames.append((msg.timestamp, msg.arbitration_id, bytes(msg.data)))

    def mark(self) -> int:
        with self._lock:
            return len(self._frames)

    def since(self, mark: int) -> list[tuple[int, bytes]]:
        with self._lock:
            return [(cob, d) for _, cob, d in self._frames[mark:]]

    def count(self, cob_id: int, since: int) -> int:
        return sum(1 for cob, _ in self.since(since) if cob == cob_id)


def wait_for(pred: Callable[[], bool], timeout_s: float, poll_s: float = 0.02) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(poll_s)
    return bool(pred())


def eds_limits(role: str, index: int, sub: int = 0) -> tuple[float | None, float | None]:
    """LowLimit/HighLimit of an object read from the EDS text (canopen drops REAL32 limits)."""
    cp = configparser.ConfigParser(interpolation=None)
    cp.optionxform = str
    cp.read(bus_config_path(f"{role}.eds"), encoding="ascii")
    name = f"{index:04X}" if f"{index:04X}sub0" not in cp else f"{index:04X}sub{sub:X}"
    sec = cp[name]

    def num(key):
        return float(sec[key]) if key in sec else None

    return num("LowLimit"), num("HighLimit")


class Lab:
    """The client side on the pair's bus: ``nodes[1]``, ``nodes[2]`` (canopen RemoteNode), ``frames``."""

    def __init__(self, port: int, pair) -> None:
        self.pair = pair
        self.bus = can.Bus(
            interface="socketcand", host="127.0.0.1", port=port, channel="telethermo", tcp_tune=True
        )
        self.net = canopen.Network(self.bus)
        self.net.NOTIFIER_CYCLE = 0.05
        self.net.connect()
        self.frames = Frames()
        self.net.notifier.add_listener(self.frames)
        self.nodes: dict[int, canopen.RemoteNode] = {}
        for nid, role in ROLE.items():
            node = canopen.RemoteNode(nid, str(bus_config_path(f"{role}.eds")))
            self.net.add_node(node)
            node.sdo.RESPONSE_TIMEOUT = 1.0
            self.nodes[nid] = node

    def sdo(self, node_id: int):
        return self.nodes[node_id].sdo

    def nmt(self, command: int, node_id: int) -> None:
        """An NMT command from us (another NMT master): canopen's NmtMaster for one node, raw for all."""
        if node_id == 0:
            self.net.send_message(0x000, bytes([command, 0]))
        else:
            self.nodes[node_id].nmt.send_command(command)

    def heartbeat_states(self, node_id: int, since: int) -> list[int]:
        return [d[0] for cob, d in self.frames.since(since) if cob == 0x700 + node_id and len(d) == 1]

    def wait_heartbeat(self, node_id: int, state: int, *, since: int, timeout_s: float = 5.0) -> bool:
        return wait_for(lambda: state in self.heartbeat_states(node_id, since), timeout_s)

    def wait_frames(self, cob_id: int, n: int, *, since: int, timeout_s: float = 20.0) -> bool:
        return wait_for(lambda: self.frames.count(cob_id, since) >= n, timeout_s)

    def emcy_codes(self, node_id: int, since: int) -> list[int]:
        return [
            int.from_bytes(d[:2], "little")
            for cob, d in self.frames.since(since)
            if cob == 0x80 + node_id and len(d) == 8
        ]

    def processes_alive(self) -> bool:
        return self.pair.master.poll() is None and self.pair.slave.poll() is None

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.net.disconnect()


@contextlib.contextmanager
def live_pair(out_dir: Path, *, timing: str = "realtime", start_timeout_s: float = 120.0) -> Iterator[Lab]:
    """The master and slave programs (simulated rigs, telepresence) over a fresh hub, running until the end
    of the block; yields the client side once the master has run 100 cycles."""

    pair = NodePair(
        PairConfig(scene=SCENE, out_dir=Path(out_dir), timing=timing, cycles=0, seed=0, progress_every=10)
    )
    pair.start()
    lab = None
    try:
        lab = Lab(pair.hub.port, pair)
        if not wait_for(lambda: pair.progress[0] >= 100, start_timeout_s):
            raise RuntimeError(f"the pair did not start (see {out_dir}/master.log)")
        yield lab
    finally:
        if lab is not None:
            lab.close()
        pair.stop()
