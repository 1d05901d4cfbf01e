"""``python -m bench.tune [telethermo tune arguments]``: a tuning run recorded as a benchmark result.

Runs ``telethermo tune`` with ``--record`` and writes the record with its provenance to
bench/results/tuning.json (bench.common.write_results), e.g.::

    python -m bench.tune --scene probe_touches_al_steel_wood --budget 40 --stress 0.15 --out gains.json
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from bench.common import write_results
from telethermo.cli.tune import main as tune_main


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    with tempfile.TemporaryDirectory() as tmp:
        record = Path(tmp) / "tuning.json"
        code = tune_main([*argv, "--record", str(record)])
        if code != 0:
            return code
        print(f"wrote {write_results('tuning', json.loads(record.read_text(encoding='utf-8')))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
