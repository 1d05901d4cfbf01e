"""``telethermo-slave``: the slave CANopen node program (see nodes/main.py and docs/nodes.md)."""

from __future__ import annotations

import sys

from telethermo.control.types import Role

from telethermo.nodes.main import run_node


def main(argv: list[str] | None = None) -> int:
    return run_node(Role.SLAVE, argv)


if __name__ == "__main__":
    sys.exit(main())
