"""`telethermo bench` runs the benchmark suite as its own process (`python -m bench`): the CLI does not
import bench/. Checked with a real child process that refuses an unknown benchmark (argparse, exit 2)
before running anything."""

import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow


def test_bench_command_runs_the_suite_as_a_process():
    r = subprocess.run(
        [sys.executable, "-m", "telethermo.cli.main", "bench", "--only", "no_such_bench"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2
    assert "python -m bench" in r.stderr and "no_such_bench" in r.stderr


def test_the_cli_does_not_import_bench():
    code = (
        "import sys; from telethermo.cli.main import build_parser; build_parser('bench'); "
        "build_parser('tune'); "
        "print(sorted(m for m in sys.modules if m == 'bench' or m.startswith('bench.')))"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"
