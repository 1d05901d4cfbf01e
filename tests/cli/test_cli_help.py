"""Every command's --help reads as text, not as reST source (issue 13: help texts showed ``literals`` and
:func:`roles`), and names the exit codes the CLI really uses."""

from __future__ import annotations

import pytest

from telethermo.cli.main import COMMANDS, build_parser, plain_text


def command_help(name: str) -> str:
    parser = build_parser(name)
    sub = next(a for a in parser._actions if a.dest == "command")  # argparse keeps subparsers here
    return sub.choices[name].format_help()


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_help_has_no_rest_markup(name):
    text = command_help(name)
    for mark in ("``", ":func:`", ":mod:`", ":class:`", "**"):
        assert mark not in text, f"{name} --help shows {mark!r}"


def test_plain_text_keeps_the_words():
    assert (
        plain_text("see :func:`~telethermo.control.rendering.calibrate_finger` and ``--live`` (**not** raw)")
        == "see telethermo.control.rendering.calibrate_finger and --live (not raw)"
    )
