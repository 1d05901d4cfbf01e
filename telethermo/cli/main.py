"""``telethermo``: one entry point, one subcommand per module of this package.

The subcommand registry (:data:`COMMANDS`) is the one place that knows which module implements which
command and the command's one-line help. Building the top-level parser imports no subcommand module:
``telethermo --help`` lists the commands from the registry, and only the chosen command's module is
imported (its ``register(subparsers)`` adds the real parser with its options and sets ``func=run``,
a callable taking the parsed args and returning an exit code). So ``--help``, ``find``, ``get``,
``set``, ``nmt`` and ``status`` import neither scipy nor matplotlib (tests/cli/test_cli_imports.py),
and one broken subcommand module cannot break the others.

Exit codes (stable, for scripts): 0 ok, 1 runtime failure (e.g. a node did not answer, SDO abort),
2 usage or input error (bad argument, bad file), 130 interrupted (Ctrl-C; `record` ends normally on
Ctrl-C: 0).
"""

from __future__ import annotations

import argparse
import importlib
import re
import signal
import sys
from typing import NamedTuple

from telethermo import __version__

# the operator's error (exit 2), defined with the remote-node client that raises it for bad names and values
from telethermo.remote.errors import UserError

EXIT_OK, EXIT_FAIL, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class Command(NamedTuple):
    module: str  # telethermo.cli.<module> defines register(subparsers)
    help: str  # the line `telethermo --help` shows; register() gets it from here


# command name -> implementing module and help, in the order `telethermo --help` lists them
COMMANDS: dict[str, Command] = {
    "session": Command(
        "session", "run a two-node telepresence session (simulated rigs) and report its figures"
    ),
    "identify": Command(
        "identify",
        "identify a TEM model (NARMA temperature + heat-flux) on a live node "
        "(and load it into it) or on a simulated rig",
    ),
    "tune": Command("tune", "tune the bilateral gains offline (search + ±30 %% robustness check)"),
    "monitor": Command("monitor", "watch the CANopen bus (live or a recorded log)"),
    "find": Command("find", "find the nodes on the bus: NMT state, identity, device name"),
    "status": Command("status", "mode, temperatures, estimates, flux, current, safety of each node"),
    "get": Command("params", "read parameters by EDS name (or list them)"),
    "set": Command("params", "write a parameter by EDS name (range-checked)"),
    "apply-gains": Command(
        "gains",
        "write a tuned gains file's gains into running nodes by SDO (and name the "
        "ones that need a restart with --gains)",
    ),
    "sdo": Command("sdo", "SDO read/write of one object of any node 1..127 (EDS or not)"),
    "nmt": Command("nmt", "NMT start/stop/preop/reset of one node or all"),
    "mode": Command("mode", "switch the nodes: telepresence | render MATERIAL | idle"),
    "fault-reset": Command("faults", "clear the latched safety trips whose cause is gone"),
    "rig": Command("rig", "rig check: verify an I/O rig's wiring (RIG.toml) before a finger goes on the pad"),
    "save": Command("store", "store a node's parameters (CiA 301 0x1010): restored at each start"),
    "restore-defaults": Command("store", "a node's default parameters from its next reset or start (0x1011)"),
    "calibrate-finger": Command("calibrate", "per-user finger calibration (yamamoto): β_pad and T_finger0"),
    "calibrate-render-table": Command(
        "calibrate_render",
        "this operator's rendering table: each material's β from direct touches of samples",
    ),
    "calibrate-material": Command(
        "calibrate_material",
        "calibrate the material identification's physics fit of this probe from recorded reference touches",
    ),
    "record": Command("record", "record the bus to a .log/.asc/.blf file plus a decoded CSV"),
    "replay": Command("replay", "send a recorded log's frames onto a bus (at the recorded pace, filtered)"),
    "dbc": Command("dbc", "write a DBC file of the PDO layout, for cantools and CAN viewers"),
    "plot": Command("plot", "plot a recording (a session's recording.csv, a node's --record CSV) to a PNG"),
    "bench": Command("bench", "run the benchmark suite, write bench/results/*.json and docs/benchmarks.md"),
    "completion": Command(
        "completion",
        "print a bash/zsh/fish completion script (commands, options, nodes, EDS names, materials, scenes)",
    ),
}


class _Subparsers:
    """What a subcommand module's ``register`` receives: ``add_parser(name, **kw)`` with the help
    text taken from :data:`COMMANDS` (a module cannot register a command the registry lacks)."""

    def __init__(self, action: argparse._SubParsersAction) -> None:
        self._action = action

    def add_parser(self, name: str, **kw) -> argparse.ArgumentParser:
        kw.setdefault("help", COMMANDS[name].help)
        if kw.get("description"):
            kw["description"] = plain_text(kw["description"])
        if kw.get("epilog"):
            kw["epilog"] = plain_text(kw["epilog"])
        return self._action.add_parser(name, **kw)


_ROLE = re.compile(r":(?:func|mod|class|meth|data|attr|obj):`~?([^`]+)`")


def plain_text(doc: str) -> str:
    """A module docstring as a person reads it in ``--help``: reST roles and literals without their marks
    (``:func:`a.b.c``` -> ``a.b.c``, double back-quotes -> the text, ``**bold**`` -> bold)."""
    text = _ROLE.sub(lambda m: m.group(1), doc)
    return text.replace("``", "").replace("**", "")


class _VersionAction(argparse.Action):
    """``--version``: the installed distribution's version, looked up only when asked (reading the
    installed metadata costs ~50 ms, which every other command would pay if the parser held the text)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(
            option_strings, dest=dest, default=default, nargs=0, help=help or "show the version and exit"
        )

    def __call__(self, parser, namespace, values, option_string=None):
        from importlib.metadata import PackageNotFoundError, version  # lazy: see the docstring

        try:
            text = version("telethermo")
        except PackageNotFoundError:  # a source tree that was never installed
            text = __version__
        print(f"telethermo {text}")
        parser.exit()


def chosen_command(argv: list[str]) -> str | None:
    """The subcommand named in ``argv`` (the first word that is not an option), or None.
    The top-level parser has only flags without values (-h, --version), so this is exact."""
    for word in argv:
        if word == "--":
            return None
        if not word.startswith("-"):
            return word
    return None


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser, with the real parser(s) of ``command``'s module (imported now) and a bare entry
    (name and help, no import) for every other command."""
    parser = argparse.ArgumentParser(
        prog="telethermo", description="Bilateral thermal telepresence over CANopen."
    )
    parser.add_argument("--version", action=_VersionAction)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    module = COMMANDS[command].module if command in COMMANDS else None
    for name, cmd in COMMANDS.items():
        if cmd.module == module:
            if name == command:  # the module registers all of its commands (get and set) at once
                importlib.import_module(f"telethermo.cli.{module}").register(_Subparsers(sub))
        else:
            sub.add_parser(name, help=cmd.help)
    return parser


def main(argv: list[str] | None = None) -> int:
    # Ctrl-C (SIGINT) is how a person stops a session, a monitor or a recording. A process started
    # in the background of a non-interactive shell inherits SIGINT *ignored*, and Python then never
    # raises KeyboardInterrupt: restore the default so that SIGINT always stops us cleanly.
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["__complete"]:  # the shell completion scripts' hidden entry (telethermo.cli.completion)
        return importlib.import_module("telethermo.cli.completion").hidden_main(argv[1:])
    parser = build_parser(chosen_command(argv))
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
