"""``telethermo completion bash|zsh|fish``: a shell completion script for the CLI.

The script asks ``telethermo __complete CWORD WORD...`` (a hidden entry point) at every Tab, so what it
offers is computed then, from the files in force: commands and each command's options and choices from its
real parser, the node names of the network file (``--network`` on the line, else the default), the EDS
parameter names of the node on the line (``get``/``set``; ``set`` offers the writable ones and an
enumeration's names as VALUE), the rendering table's materials (``mode render``, ``--table`` on the line),
the shipped scene names (``--scene``). A word it knows nothing about (a file) is left to the shell's file
completion.

    telethermo completion bash > ~/.local/share/bash-completion/completions/telethermo
    telethermo completion zsh > "${fpath[1]}/_telethermo"        # or: source <(telethermo completion zsh)
    telethermo completion fish > ~/.config/fish/completions/telethermo.fish
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

from telethermo.cli import common
from telethermo.cli.main import COMMANDS, build_parser
from telethermo.control.render_table import load_render_table
from telethermo.device.netconfig import NetworkConfigError, load_network
from telethermo.remote import values
from telethermo.remote.errors import UserError
from telethermo.remote.targets import eds_info, node_targets, resolve_node

SHELLS = ("bash", "zsh", "fish")
HIDDEN = "__complete"
#: commands whose first positional is a node of the network file (and every later one for these)
NODE_LISTS = {"status", "fault-reset", "save", "restore-defaults"}
NODE_FIRST = {"get", "set", "sdo", "identify"}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "completion", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("shell", choices=SHELLS, help="the shell to complete in")
    p.set_defaults(func=run)


def _sub(name: str) -> argparse.ArgumentParser:
    parser = build_parser(name)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name]


def command_words(name: str) -> list[str]:
    """The option strings and fixed choices of ``telethermo NAME``, from its real parser."""
    words: list[str] = []
    for action in _sub(name)._actions:
        words += [o for o in action.option_strings if o.startswith("--") or len(o) == 2]
        if action.choices and not action.option_strings and not isinstance(action.choices, dict):
            words += [str(c) for c in action.choices]
    return sorted(set(words))


def _valued_options(parser: argparse.ArgumentParser) -> set[str]:
    return {o for a in parser._actions if a.option_strings and a.nargs != 0 for o in a.option_strings}


def _split(parser: argparse.ArgumentParser, words: list[str]) -> tuple[list[str], dict[str, str]]:
    """The positionals and the options' values among ``words`` (the command's words before the cursor)."""
    valued = _valued_options(parser)
    pos: list[str] = []
    opts: dict[str, str] = {}
    i = 0
    while i < len(words):
        w = words[i]
        if w.startswith("-") and "=" in w:
            k, v = w.split("=", 1)
            opts[k] = v
        elif w in valued:
            opts[w] = words[i + 1] if i + 1 < len(words) else ""
            i += 1
        elif not w.startswith("-"):
            pos.append(w)
        i += 1
    return pos, opts


def shipped_scenes() -> list[str]:
    """telethermo.sim.scene.shipped_scenes without importing the simulator (scipy: ~1 s a Tab on a loaded
    machine): the names of sim/scenes/*.toml, found through the package's location."""
    spec = importlib.util.find_spec("telethermo.sim")
    folders = list(spec.submodule_search_locations or []) if spec is not None else []
    return sorted(p.stem for d in folders for p in (Path(d) / "scenes").glob("*.toml"))


def _nodes(opts: dict[str, str]) -> list[str]:
    try:
        return [t.role for t in node_targets(load_network(opts.get("--network")))]
    except (NetworkConfigError, OSError):
        return []


def _eds_names(opts: dict[str, str], node: str, writable: bool = False) -> list[str]:
    try:
        t = resolve_node(load_network(opts.get("--network")), node)
        return sorted(v.key for v in eds_info(t).vars.values() if v.writable or not writable)
    except (UserError, NetworkConfigError, OSError):
        return []


def _enum_value(opts: dict[str, str], node: str, name: str) -> list[str]:
    try:
        t = resolve_node(load_network(opts.get("--network")), node)
        info = next(v for v in eds_info(t).vars.values() if v.key == name)
    except (UserError, NetworkConfigError, OSError, StopIteration):
        return []
    return list((values.enum_names(info) or {}).values())


def _positional(cmd: str, pos: list[str], opts: dict[str, str], choices: list[str]) -> list[str]:
    """Candidates for the positional after ``pos`` of ``cmd``."""
    n = len(pos)
    if cmd in ("get", "set") and n >= 1:
        if cmd == "get" or n == 1:
            return _eds_names(opts, pos[0], writable=cmd == "set")
        return _enum_value(opts, pos[0], pos[1]) if n == 2 else []
    if cmd == "mode":
        if n == 0:
            return choices
        if n == 1 and pos[0] == "render":
            try:
                return list(load_render_table(opts.get("--table")))
            except ValueError:
                return []
        return []
    if cmd == "nmt":
        return choices if n == 0 else (_nodes(opts) + ["all"] if n == 1 else [])
    if cmd in NODE_LISTS or (cmd in NODE_FIRST and n == 0) or (cmd == "apply-gains" and n >= 1):
        return _nodes(opts)
    return choices


def complete(words: list[str], cword: int) -> list[str]:
    """What to offer for ``words[cword]`` on the line ``words`` (``words[0]`` is ``telethermo``)."""
    words = list(words) + [""] * (cword + 1 - len(words))
    cur = words[cword]
    if cword <= 1:
        return [w for w in list(COMMANDS) + ["--help", "--version"] if w.startswith(cur)]
    cmd = words[1]
    if cmd not in COMMANDS:
        return []
    parser = _sub(cmd)
    pos, opts = _split(parser, words[2:cword])
    prev = words[cword - 1]
    if prev in _valued_options(parser):
        action = next(a for a in parser._actions if prev in a.option_strings)
        if prev == "--scene":
            found = list(shipped_scenes())
        else:
            found = [str(c) for c in action.choices] if action.choices else []
        return [w for w in found if w.startswith(cur)]  # nothing: the shell completes a file name
    if cur.startswith("-"):
        return [w for w in command_words(cmd) if w.startswith(cur) and w.startswith("-")]
    choices = [
        str(c)
        for a in parser._actions
        if a.choices and not a.option_strings and not isinstance(a.choices, dict)
        for c in a.choices
    ]
    return [w for w in _positional(cmd, pos, opts, choices) if w.startswith(cur)]


def hidden_main(argv: list[str]) -> int:
    """``telethermo __complete CWORD WORD...``: one candidate a line (what the completion scripts call)."""
    try:
        cword = int(argv[0])
    except (IndexError, ValueError):
        print(f"telethermo {HIDDEN}: usage: telethermo {HIDDEN} CWORD WORD...", file=sys.stderr)
        return 2
    for w in complete(argv[1:], cword):
        print(w)
    return 0


BASH = r"""# telethermo shell completion (telethermo completion bash): asks telethermo at each Tab
_telethermo() {
    local IFS=$'\n'
    COMPREPLY=($(telethermo __complete "$COMP_CWORD" "${COMP_WORDS[@]:0:COMP_CWORD+1}" 2>/dev/null))
    COMPREPLY=("${COMPREPLY[@]// /\\ }")      # EDS names with spaces ('Identity object.Vendor-ID')
}
complete -o default -F _telethermo telethermo
"""

ZSH = r"""#compdef telethermo
# telethermo shell completion (telethermo completion zsh): asks telethermo at each Tab
_telethermo() {
    local -a found
    found=("${(@f)$(telethermo __complete $((CURRENT - 1)) "${(@)words[1,CURRENT]}" 2>/dev/null)}")
    found=(${found:#})
    if (( ${#found} )); then compadd -a found; else _files; fi
}
compdef _telethermo telethermo
"""

FISH = r"""# telethermo shell completion (telethermo completion fish): asks telethermo at each Tab
function __telethermo_complete
    set -l words (commandline -opc)
    set -l cur (commandline -ct)
    set -l found (telethermo __complete (count $words) $words $cur 2>/dev/null)
    if test (count $found) -gt 0
        printf '%s\n' $found
    else
        __fish_complete_path $cur
    end
end
complete -c telethermo -f -a '(__telethermo_complete)'
"""


@common.failures
def run(args: argparse.Namespace) -> int:
    print({"bash": BASH, "zsh": ZSH, "fish": FISH}[args.shell], end="")
    return 0
