"""What the CLI prints of text it did not write (a robot's error details, a server's
message) never carries a control character to the terminal (issue 31)."""

from __future__ import annotations

import pytest

import d3dwa_bullet.cli.app as app
from d3dwa_bullet.cli.output import printable
from d3dwa_bullet.errors import ConfigError


@pytest.mark.parametrize(
    ("text", "shown"),
    [
        ("clear\x1b[2J\x1b[H", "clear\\x1b[2J\\x1b[H"),
        ("title\x1b]0;pwned\x07", "title\\x1b]0;pwned\\x07"),
        ("csi\x9b31m", "csi\\x9b31m"),  # the C1 control sequence introducer
        ("back\rspace\x08", "back\\rspace\\x08"),
        ("bidi\u202eflip", "bidi\\u202eflip"),
        ("lone\udcff", "lone\\udcff"),  # a byte a file name decoded with surrogateescape
        ("plain: 0.3 m/s, 90°, ok", "plain: 0.3 m/s, 90°, ok"),
    ],
)
def test_printable_escapes_control_characters_and_keeps_the_rest(text, shown):
    assert printable(text) == shown


def test_the_error_line_is_printed_escaped(capsys, monkeypatch):
    def fail(args):
        raise ConfigError("robot said: \x1b]0;pwned\x07\x1b[2Jdone")

    parser = app.build_parser
    monkeypatch.setattr(app, "build_parser", lambda: _with_func(parser(), fail))
    assert app.main(["worlds"]) == 2
    err = capsys.readouterr().err
    assert err == "d3dwa: error: robot said: \\x1b]0;pwned\\x07\\x1b[2Jdone\n"


def test_the_interrupted_line_is_printed_escaped(capsys, monkeypatch):
    def interrupted(args):
        raise KeyboardInterrupt("robot said \x07")

    parser = app.build_parser
    monkeypatch.setattr(app, "build_parser", lambda: _with_func(parser(), interrupted))
    assert app.main(["worlds"]) == 130
    assert capsys.readouterr().err == "d3dwa: interrupted; robot said \\x07\n"


def _with_func(parser, func):
    """parser whose ``worlds`` command runs func."""
    for action in parser._subparsers._group_actions:  # argparse keeps sub-parsers here
        action.choices["worlds"].set_defaults(func=func)
    return parser
