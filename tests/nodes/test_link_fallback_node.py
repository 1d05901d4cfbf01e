"""Graceful link loss between the two node programs: kill the slave while its probe touches an object it has
identified; the master renders that material locally (EMCY 0xFF01, link_fallback_active), for its
link_loss_render_s (5 s), within the envelope, then ramps to neutral and cuts as before (peer_lost).
Observed from a third client on the hub and from the master's recording."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from telethermo.cia301 import EMCY_LINK_FALLBACK
from telethermo.nodes.launch import NodePair, PairConfig, wait_for
from telethermo.recording.format import read_recording_csv

from tests.nodes.test_peer_loss import MISS_LIMIT, PERIOD_S, RAMP_C_PER_S, Observer

pytestmark = pytest.mark.slow  # starts processes

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
RENDER_S = 5.0  # CoreParams.link_loss_render_s default (0x2618)


def test_slave_killed_during_an_identified_touch(tmp_path):
    pair = NodePair(PairConfig(scene=SCENE, out_dir=tmp_path, cycles=0, seed=0, progress_every=10))
    pair.start()
    obs = Observer(pair.hub.port)
    try:
        # the probe touches aluminium from 1.0 s, identified 0.3 s later; kill it at 2 s, mid-touch
        assert wait_for(lambda: pair.progress[0] >= 200, 120), "session did not start"
        pair.slave.kill()
        pair.slave.wait()
        k_kill = pair.progress[0]
        assert wait_for(lambda: obs.emcy(1, EMCY_LINK_FALLBACK), 30), "no EMCY 0xFF01 from the master"
        # the master goes on (paced by the SYNC period): the fallback's 5 s, the ramp to neutral, the cut
        assert wait_for(lambda: pair.progress[0] >= k_kill + RENDER_S / PERIOD_S + 300, 120)
    finally:
        obs.close()
        codes = pair.stop()
    assert codes["master"] == 0
    rec = read_recording_csv(tmp_path / "master.csv")
    peer = rec.col("m_peer_estimate_C")
    k_trip = next(k for k, t in enumerate(rec.text("m_new_trips")) if "peer_lost" in t)
    k_last = (np.flatnonzero(np.diff(peer[: k_trip + 1]) != 0) + 1)[-1]  # the last fresh peer value
    # declared lost after the miss limit, then the fallback's 5 s, then the envelope's peer trip
    assert RENDER_S / PERIOD_S <= k_trip - k_last <= RENDER_S / PERIOD_S + MISS_LIMIT + 5
    fb = slice(k_last + MISS_LIMIT + 2, k_trip)
    state, sp, cur = rec.col("m_safety_state")[fb], rec.col("m_setpoint_C")[fb], rec.col("m_current_A")[fb]
    assert np.all(state < 2)  # no peer trip while the fallback renders
    assert np.all((15.0 <= sp) & (sp <= 43.0))
    assert np.all(np.abs(np.diff(sp)) <= RAMP_C_PER_S * PERIOD_S + 1e-9)
    assert np.all(np.abs(cur) <= 2.4 + 1e-9) and np.count_nonzero(cur) == cur.size
    # the rendered aluminium is colder than the finger (about 25-27 °C), not the neutral 32 °C
    assert np.all(sp[-100:] < 29.0)
    after = rec.col("m_safety_state")[k_trip:]
    assert np.all(after >= 2) and np.any(after == 3)  # ramp to neutral, then cut, as before
