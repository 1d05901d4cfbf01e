"""Bus configuration: EDS files and network settings (the source of truth for the CANopen contract)."""

from pathlib import Path

DIR = Path(__file__).resolve().parent


def path(name: str) -> Path:
    """Absolute path of a file shipped in bus_config/ (e.g. ``path("master.eds")``)."""
    return DIR / name
