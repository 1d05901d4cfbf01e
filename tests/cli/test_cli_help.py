"""Every command's --help (and every sub-action's, ``rig check``) reads as text, not as reST source (issue 13:
help texts showed ``literals`` and :func:`roles`), cites no issue numbers, and names the exit codes the CLI
really uses."""

from __future__ import annotations

import argparse
import re

import pytest

from telethermo.cli.main import COMMANDS, build_parser, plain_text


def command_helps(name: str) -> dict[str, str]:
    """The --help of command ``name`` and of each of its sub-actions (``rig check``), by command line."""
    parser = build_parser(name)
    sub = next(a for a in parser._actions if a.dest == "command")  # argparse keeps subparsers here
    out, todo = {}, [(name, sub.choices[name])]
    while todo:
        line, p = todo.pop()
        out[line] = p.format_help()
        for a in p._actions:
            if isinstance(a, argparse._SubParsersAction):
                todo += [(f"{line} {n}", c) for n, c in a.choices.items()]
    return out


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_help_has_no_rest_markup_nor_issue_numbers(name):
    for line, text in command_helps(name).items():
        for mark in ("``", ":func:`", ":mod:`", ":class:`", "**"):
            assert mark not in text, f"{line} --help shows {mark!r}"
        assert not re.search(r"\bissues? \d", text, re.IGNORECASE), f"{line} --help cites an issue number"


def test_nested_actions_are_checked_too():
    assert "rig check" in command_helps("rig")


def test_plain_text_keeps_the_words():
    assert (
        plain_text("see :func:`~telethermo.control.rendering.calibrate_finger` and ``--live`` (**not** raw)")
        == "see telethermo.control.rendering.calibrate_finger and --live (not raw)"
    )
