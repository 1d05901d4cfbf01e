"""``telethermo dbc --out FILE``: the network file's PDO layout as a DBC file (:mod:`telethermo.monitor.dbc`),
for cantools, SavvyCAN, BusMaster or a commercial viewer to decode our traffic. One message per TPDO, a signal
per mapped object with its unit, floats declared as IEEE, material codes with their names. The mapping is
the EDS's (with the network file's nodes): a PDO remapped at run time is not in it."""

from __future__ import annotations

import argparse
from pathlib import Path

from telethermo.atomic import write_text_atomic
from telethermo.cli import common
from telethermo.cli.main import UserError
from telethermo.cli.monitor_setup import monitor_config
from telethermo.monitor.dbc import dbc_text


def register(subparsers) -> None:
    p = subparsers.add_parser("dbc", description=__doc__)
    p.add_argument("--out", metavar="FILE", type=Path, required=True, help="the DBC file to write (.dbc)")
    p.add_argument("--network", metavar="FILE", help="network settings (default: bus_config/network.toml)")
    p.add_argument("--force", action="store_true", help="replace an existing file")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    out: Path = args.out
    if out.suffix.lower() != ".dbc":
        raise UserError(f"--out {out}: expected a .dbc file name")
    if not out.parent.is_dir():
        raise UserError(f"--out {out}: the folder {out.parent} does not exist; expected an existing folder")
    if out.exists() and not args.force:
        raise UserError(f"--out {out}: already exists; give another name, or --force to replace")
    cfg = monitor_config(common.network(args))
    text = dbc_text({n: i.od for n, i in cfg.nodes.items()}, {n: i.name for n, i in cfg.nodes.items()})
    try:
        write_text_atomic(out, text)
    except OSError as exc:
        raise UserError(f"--out {out}: cannot write ({exc.strerror or exc})") from None
    lines = text.splitlines()
    print(
        f"{out}: {sum(ln.startswith('BO_ ') for ln in lines)} messages, "
        f"{sum(ln.startswith(' SG_ ') for ln in lines)} signals"
    )
    return 0
