"""A test process with no bus setting of this machine's: no CAN_* variables, python-can config files only
under a HOME of the test's own, no published hub (its own runtime dir), and the test's folder as the working
directory (no ./can.ini)."""

from __future__ import annotations

from pathlib import Path

import can
import pytest

ENV_KEYS = ("CAN_INTERFACE", "CAN_CHANNEL", "CAN_BITRATE", "CAN_CONFIG")


def isolate_bus_settings(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Isolate (see the module docstring); returns the HOME made under ``tmp_path``."""
    home = tmp_path / "home"
    home.mkdir()
    (tmp_path / "run").mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path / "run"))
    for key in ENV_KEYS:
        monkeypatch.delenv(key, raising=False)
        monkeypatch.delenv(f"{key}_telethermo", raising=False)
    monkeypatch.setattr(can.util, "CONFIG_FILES", [p for p in can.util.CONFIG_FILES if p.startswith("~")])
    monkeypatch.chdir(tmp_path)
    return home
