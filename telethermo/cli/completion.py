"""``telethermo completion bash|zsh``: a shell completion script for the CLI, made from the command
registry and every command's own parser (so it cannot drift from the options), with the node names of the
network file and the shipped scene names as words.

    telethermo completion bash > ~/.local/share/bash-completion/completions/telethermo
    eval "$(telethermo completion zsh)"        # zsh: bash completion through bashcompinit
"""
from __future__ import annotations

import argparse
import shlex

from telethermo.cli import common
from telethermo.cli.main import COMMANDS, build_parser
from telethermo.sim.scene import shipped_scenes

SHELLS = ("bash", "zsh")


def register(subparsers) -> None:
    p = subparsers.add_parser("completion", description=__doc__)
    p.add_argument("shell", choices=SHELLS, help="the shell to complete in")
    p.add_argument("--network", help="network file whose node names complete NODE (default: the shipped one)")
    p.set_defaults(func=run)


def command_words(name: str) -> list[str]:
    """The option strings and fixed choices of ``telethermo NAME``, from its real parser."""
    parser = build_parser(name)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    words: list[str] = []
    for action in sub.choices[name]._actions:
        words += [o for o in action.option_strings if o.startswith("--") or len(o) == 2]
        if action.choices and not action.option_strings and not isinstance(action.choices, dict):
            words += [str(c) for c in action.choices]
    return sorted(set(words))


def script(node_names: list[str], scenes: list[str]) -> str:
    """A bash completion function (zsh loads it through bashcompinit)."""
    cases = []
    for name in COMMANDS:
        cases.append(f"        {shlex.quote(name)}) words={shlex.quote(' '.join(command_words(name)))} ;;")
    names = " ".join(COMMANDS)
    return f"""# telethermo shell completion (telethermo completion bash); regenerate after an upgrade
_telethermo() {{
    local cur=${{COMP_WORDS[COMP_CWORD]}} prev=${{COMP_WORDS[COMP_CWORD-1]}} words=""
    if [ "$COMP_CWORD" -eq 1 ]; then
        COMPREPLY=($(compgen -W "{names} --help --version" -- "$cur")); return
    fi
    case "$prev" in
        --scene) COMPREPLY=($(compgen -f -- "$cur") $(compgen -W "{' '.join(scenes)}" -- "$cur")); return ;;
        --network|--out|--model|--gains|--record|--replay|--save-data|--plot|--tem) COMPREPLY=($(compgen -f -- "$cur")); return ;;
    esac
    case "${{COMP_WORDS[1]}}" in
{chr(10).join(cases)}
    esac
    COMPREPLY=($(compgen -W "$words {' '.join(node_names)} all" -- "$cur"))
}}
complete -o default -F _telethermo telethermo
"""


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    text = script(sorted(net.nodes), list(shipped_scenes()))
    if args.shell == "zsh":
        text = "autoload -U +X bashcompinit && bashcompinit\n" + text
    print(text, end="")
    return 0
