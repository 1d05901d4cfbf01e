"""``python -m bench --check``: the targets are data, checked per key from the result files (met, short,
missing), exit 1 when one is short. Run as the program (tests do not import bench/)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow  # starts the bench program


def check(results: Path) -> tuple[int, dict[str, str]]:
    p = subprocess.run(
        [sys.executable, "-m", "bench", "--check", "--results-dir", str(results)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    verdicts = {}
    for line in p.stdout.splitlines():
        cells = line.split()
        if len(cells) >= 5 and cells[0] in {"stress", "material_id", "envelope", "sim"}:
            verdicts[f"{cells[0]}.{cells[1]}"] = next(c for c in cells if c in {"met", "short", "missing"})
    return p.returncode, verdicts


def test_met_short_and_missing_per_key(tmp_path):
    (tmp_path / "stress.json").write_text(json.dumps({"n_failed": 0, "surface_rate_max_C_per_s": 5.9}))
    (tmp_path / "material_id.json").write_text(json.dumps({"material_id_ci95_coverage": 0.95}))
    code, v = check(tmp_path)
    assert code == 0, v  # nothing short: missing files and keys do not fail
    assert v["stress.n_failed"] == "met" and v["stress.surface_rate_max_C_per_s"] == "met"
    assert v["material_id.material_id_ci95_coverage"] == "met"
    assert v["material_id.material_id_envelope_accuracy_late"] == "missing"
    assert v["envelope.envelope_n_conditions"] == "missing" and v["sim.realtime_factor"] == "missing"

    (tmp_path / "stress.json").write_text(json.dumps({"n_failed": 1, "surface_rate_max_C_per_s": 6.5}))
    (tmp_path / "material_id.json").write_text(json.dumps({"material_id_ci95_coverage": 0.99}))
    code, v = check(tmp_path)
    assert code == 1
    assert v["stress.n_failed"] == "short" and v["stress.surface_rate_max_C_per_s"] == "short"
    assert v["material_id.material_id_ci95_coverage"] == "short"  # above the band is short too
