"""The ``podid-rs`` command line: argument parsing, usage errors, progress line.

The end-to-end ``podid-rs paper --quick`` run is in ``test_paper.py``.
"""

from __future__ import annotations

import io
import subprocess
import sys

import pytest

from podid_rs import __version__
from podid_rs._progress import Progress
from podid_rs.apps.cli import build_parser, main, parse_lam


def test_parse_lam_one_or_three_values_or_a_rule():
    assert parse_lam(["100"]) == 100.0
    assert parse_lam(["1e2", "50", "0"]) == (100.0, 50.0, 0.0)
    for rule in ("lcurve", "gcv", "discrepancy"):
        assert parse_lam([rule]) == rule


@pytest.mark.parametrize(
    ("tokens", "message"),
    [
        (["1", "2"], "one value or three"),
        (["1", "2", "3", "4"], "one value or three"),
        (["abc"], "not a number"),
        (["-1"], "non-negative"),
        (["nan"], "finite"),
        (["1", "inf", "1"], "finite"),
    ],
)
def test_parse_lam_rejects(tokens, message):
    with pytest.raises(ValueError, match=message):
        parse_lam(tokens)


def test_paper_defaults():
    args = build_parser().parse_args(["paper"])
    assert (args.out, args.quick, args.seed, args.energy, args.no_progress) == (
        "podid-results", False, 0, None, False)
    assert parse_lam(args.lam) == 100.0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        ([], "required: COMMAND"),
        (["nonsense"], "invalid choice"),
        (["paper", "--lam", "1", "2"], "--lam takes one value or three"),
        (["paper", "--lam", "x"], "'x' is not a number"),
        (["paper", "--energy", "0"], "fraction in (0, 1]"),
        (["paper", "--energy", "1.2"], "fraction in (0, 1]"),
        (["paper", "--energy", "most"], "not a number"),
        (["paper", "--seed", "-3"], "non-negative integer"),
        (["paper", "--seed", "1.5"], "not an integer"),
        (["paper", "--frobnicate"], "unrecognized arguments"),
    ],
)
def test_bad_arguments_exit_2_with_a_clear_message(argv, message, capsys, tmp_path,
                                                   monkeypatch):
    monkeypatch.chdir(tmp_path)  # nothing may be written, but if it were, not here
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_unwritable_output_is_an_error_not_a_traceback(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    assert main(["paper", "--quick", "--no-progress", "--out", str(blocker / "sub")]) == 1
    assert "podid-rs paper: error:" in capsys.readouterr().err


def test_python_dash_m_runs_the_cli():
    out = subprocess.run([sys.executable, "-m", "podid_rs", "--version"],
                         capture_output=True, text=True, check=True)
    assert __version__ in out.stdout


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_is_quiet_off_a_terminal():
    s = io.StringIO()
    bar = Progress(3, stream=s)
    for label in ("one", "two", "three"):
        bar.step(label)
    bar.close()
    assert s.getvalue() == ""


def test_progress_terminal_redraws_in_place_and_can_be_disabled():
    s = _Terminal()
    bar = Progress(2, stream=s)
    bar.step("a")
    bar.step("b")
    bar.close()
    text = s.getvalue()
    assert "\r" in text and "1/2" in text and "step/s, b]" in text
    assert text.endswith("done]\n") and "100%" in text

    quiet = _Terminal()
    bar = Progress(2, enabled=False, stream=quiet)
    bar.step("a")
    bar.close()
    assert quiet.getvalue() == ""
