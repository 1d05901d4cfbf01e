"""`--gains FILE` (a `telethermo tune --out` file) reaches both node processes: their lockstep run equals
the offline runner given the same tuned gains, and differs from the run with the shipped gains."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from telethermo.nodes.launch import NodePair, PairConfig
from telethermo.recording.merge import merge_recordings
from telethermo.control.gainsfile import GAINS_FORMAT, load_gains
from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.offline import run_offline_session

pytestmark = pytest.mark.slow  # starts processes

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
CYCLES = 200  # the probe touches the aluminium at 1.0 s (cycle 100)


def _gains_file(tmp_path: Path) -> Path:
    m, s = default_params(Role.MASTER), default_params(Role.SLAVE)
    doc = {
        "format": GAINS_FORMAT,
        "period_s": 0.01,
        "master": {"kp_A_per_C": m.kp_A_per_C * 0.7, "ki_A_per_C_s": m.ki_A_per_C_s * 1.3},
        "slave": {"kp_A_per_C": s.kp_A_per_C * 1.2},
    }
    p = tmp_path / "gains.json"
    p.write_text(json.dumps(doc), encoding="utf-8")
    return p


def test_tuned_gains_reach_both_nodes(tmp_path):
    gains = _gains_file(tmp_path)
    args = ["--gains", str(gains)]
    pair = NodePair(
        PairConfig(
            scene=SCENE, out_dir=tmp_path / "run", cycles=CYCLES, seed=0, master_args=args, slave_args=args
        )
    )
    with pair:
        assert pair.wait_master(timeout_s=180) == 0, (tmp_path / "run" / "master.log").read_text()
    pair.stop()
    rec = merge_recordings(tmp_path / "run" / "master.csv", tmp_path / "run" / "slave.csv", scene=SCENE)

    g = load_gains(gains)
    tuned = run_offline_session(
        SCENE,
        duration_s=CYCLES * 0.01,
        rounding="real32",
        seed=0,
        master_params=default_params(Role.MASTER, **g[Role.MASTER]),
        slave_params=default_params(Role.SLAVE, **g[Role.SLAVE]),
    ).recording
    shipped = run_offline_session(SCENE, duration_s=CYCLES * 0.01, rounding="real32", seed=0).recording
    for col in ("m_current_A", "s_current_A"):
        np.testing.assert_allclose(rec.col(col), tuned.col(col), rtol=0, atol=1e-9, err_msg=col)
        # the gains changed something: the shipped gains give other currents once the probe touches
        assert np.nanmax(np.abs(rec.col(col) - shipped.col(col))) > 1e-3, col


@pytest.mark.parametrize(
    "doc, fragment",
    [
        ({"format": "nope"}, "telethermo.gains/1"),
        ({"format": GAINS_FORMAT, "master": {"kp": 1.0}, "slave": {}}, "master.kp"),
    ],
)
def test_bad_gains_file_is_refused_with_its_field(tmp_path, doc, fragment):
    import subprocess
    import sys

    p = tmp_path / "g.json"
    p.write_text(json.dumps(doc), encoding="utf-8")
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "telethermo.cli.main",
            "session",
            "--scene",
            str(SCENE),
            "--out",
            str(tmp_path / "o"),
            "--gains",
            str(p),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2 and fragment in r.stderr and "Traceback" not in r.stderr
