"""``python -m telethermo``: the ``telethermo`` command (as ``python -m can.viewer`` runs can.viewer)."""

import sys

from telethermo.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
