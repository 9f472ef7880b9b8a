"""`python -m tools.soak`'s options: malformed ones end with one line and exit 2."""

from __future__ import annotations

import pytest

from tools.soak.run import parse


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--hours", "-1"], "--hours and --interval must be positive"),
        (["--interval", "0"], "--hours and --interval must be positive"),
        (["--hours", "x"], "invalid float value: 'x'"),
        (["--kinds", "kill,melt"], "--kinds: no fault kind 'melt'"),
        (["--kinds", "cut"], "--kinds: cut needs --link-cuts"),
        (["--kill", "points,toaster"], "--kill: no process 'toaster'"),
    ],
)
def test_malformed_options_are_one_line_and_exit_2(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        parse(argv)
    assert exited.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith("python -m tools.soak: error: ") and message in last


def test_the_defaults_parse() -> None:
    args = parse([])
    assert args.hours > 0 and args.interval > 0 and "kill" in args.kinds.split(",")
