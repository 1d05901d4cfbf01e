"""Options of the whole suite.

``--no-processes`` (``make test-fast``, the inner loop): a test that starts a process (``subprocess``,
``multiprocessing``, a process pool) fails at once with a message saying to mark it ``slow``, so the fast
tier stays free of processes by construction, not by a list kept by hand.

``--write-results DIR``: the stress and conformance tests write their JSON results (``stress.json``,
``conformance.json``) into DIR (what ``python -m bench.stress`` and ``python -m bench.conformance_bench``
ask for); see tests/support/results.py (fixture ``results_writer``).

Every test's node programs and in-process nodes keep their CiA 301 parameter store (0x1010, default
``$XDG_STATE_HOME/telethermo/node<ID>.json``) in a folder of this test run, never in the user's: settings a
developer saved must not change what the tests see. Set at import, before any fixture starts a process.

Every canopen SDO client the tests build waits :data:`SDO_RESPONSE_TIMEOUT_S` for an answer unless the test
sets its own (canopen's default, 0.3 s, is shorter than a node process on a loaded machine can take: two CI
runs beside CPU hogs failed on it). No test asserts a time with it; the tests that check a timeout set theirs.
"""

from __future__ import annotations

import multiprocessing.process
import os
import subprocess
import tempfile

import canopen.sdo.client
import pytest

from tests.support.results import ResultsWriter

os.environ["XDG_STATE_HOME"] = tempfile.mkdtemp(prefix="telethermo-test-state-")

SDO_RESPONSE_TIMEOUT_S = 3.0
canopen.sdo.client.SdoClient.RESPONSE_TIMEOUT = SDO_RESPONSE_TIMEOUT_S


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("telethermo")
    group.addoption(
        "--no-processes",
        action="store_true",
        help="fail any test that starts a process (the fast tier: mark such tests `slow`)",
    )
    group.addoption(
        "--write-results",
        metavar="DIR",
        help="write the stress / conformance results (stress.json, conformance.json) into DIR",
    )
    group.addoption(
        "--stress-size",
        choices=("quick", "full"),
        help="run the stress suite's cases (tests/stress/test_stress_suite.py) at this size",
    )
    group.addoption(
        "--stress-only", nargs="+", metavar="CASE", default=None, help="with --stress-size: only these cases"
    )
    group.addoption(
        "--conformance-timing",
        nargs="+",
        choices=("realtime", "lockstep"),
        default=None,
        help="timing modes of the live pair for the conformance checks (default: realtime)",
    )


_SAVED: dict[str, object] = {}


def _refuse(*_args, **_kwargs):
    raise RuntimeError(
        "this test starts a process, which the fast tier (--no-processes, make test-fast) does "
        "not allow: mark it `slow` (pytestmark = pytest.mark.slow)"
    )


def _warm_font_cache() -> None:
    """matplotlib (the optional ``plot`` extra) lists the system's fonts with ``fc-list`` the first time it
    builds its font cache: on a fresh machine that was the first plotting test's process, refused by the fast
    tier. Built here, before the guard, it is not a test's process."""
    try:
        import matplotlib.font_manager  # noqa: F401  (optional extra: imported only to build its cache)
    except ImportError:
        pass


def pytest_configure(config: pytest.Config) -> None:
    """With --no-processes, starting a process raises for the whole session (module-scoped fixtures too)."""
    if config.getoption("--no-processes"):
        _warm_font_cache()
        _SAVED["popen"] = subprocess.Popen.__init__
        _SAVED["start"] = multiprocessing.process.BaseProcess.start
        subprocess.Popen.__init__ = _refuse  # type: ignore[method-assign]
        multiprocessing.process.BaseProcess.start = _refuse  # type: ignore[method-assign]


def pytest_unconfigure(config: pytest.Config) -> None:
    if _SAVED:
        subprocess.Popen.__init__ = _SAVED.pop("popen")  # type: ignore[method-assign]
        multiprocessing.process.BaseProcess.start = _SAVED.pop("start")  # type: ignore[method-assign]


@pytest.fixture(scope="session")
def results_writer(request: pytest.FixtureRequest):
    """Collects the stress / conformance entries; writes them at the end when --write-results DIR is given."""
    writer = ResultsWriter(request.config.getoption("--write-results"))
    yield writer
    writer.write()
