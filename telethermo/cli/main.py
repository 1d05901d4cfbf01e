"""``telethermo``: one entry point, one subcommand per module of this package.

Each subcommand module defines ``register(subparsers)`` which adds its parser and sets
``func=run`` (a callable taking the parsed args and returning an exit code). Modules are imported
lazily so that ``telethermo --help`` stays fast and one broken subcommand cannot break the others.

Exit codes (stable, for scripts): 0 ok, 1 runtime failure (e.g. a node did not answer, SDO abort),
2 usage or input error (bad argument, bad file), 130 interrupted (Ctrl-C).
"""
from __future__ import annotations

import argparse
import importlib
import signal
import sys

EXIT_OK, EXIT_FAIL, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130

# subcommand module names (telethermo.cli.<name>); each has register(subparsers)
SUBCOMMAND_MODULES = [
    "session", "identify", "tune", "monitor", "find", "status", "params", "nmt", "mode", "faults", "calibrate", "record", "bench",
]


class UserError(Exception):
    """An error the user can fix (bad argument, bad file, unknown parameter): one line, exit 2."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="telethermo", description="Bilateral thermal telepresence over CANopen.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMAND_MODULES:
        try:
            mod = importlib.import_module(f"telethermo.cli.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"telethermo.cli.{name}":
                continue  # not built (yet)
            raise
        mod.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    # Ctrl-C (SIGINT) is how a person stops a session, a monitor or a recording. A process started
    # in the background of a non-interactive shell inherits SIGINT *ignored*, and Python then never
    # raises KeyboardInterrupt: restore the default so that SIGINT always stops us cleanly.
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_USAGE
    try:
        return int(args.func(args) or 0)
    except UserError as exc:
        print(f"telethermo {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"telethermo {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    # `python -m telethermo.cli.main`: run the imported module's main, so that the subcommands' UserError
    # (telethermo.cli.main.UserError) is the class caught here, not a second __main__.UserError
    from telethermo.cli.main import main as _main

    sys.exit(_main())
