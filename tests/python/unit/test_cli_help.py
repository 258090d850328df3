"""The help of every ``rrr`` command: a description and an example; each ``rrr hil`` action
lists only its own options, and an option of another action is an error."""

from __future__ import annotations

import argparse
import re
import shlex
import subprocess
import sys

import pytest
from rrr_robot.cli import build_parser


def commands(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
             ) -> list[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    """Every command below ``parser`` (``rrr hil`` and its actions too), with its path."""
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found.append(((*path, name), sub))
                found += commands(sub, (*path, name))
    return found


ALL = commands(build_parser())


def options(parser: argparse.ArgumentParser) -> set[str]:
    return {o for a in parser._actions for o in a.option_strings} - {"-h", "--help"}


def test_the_tree_has_every_command() -> None:
    names = {" ".join(path) for path, _ in ALL}
    assert {"fmus", "writing", "identify", "identify-experiment", "urdf", "ssp", "run-ssp",
            "sweep", "hil", "hil bench", "hil controller", "hil plant", "hil export-reference",
            "hil busload", "hil canopen"} <= names


@pytest.mark.parametrize("path", [" ".join(p) for p, _ in ALL])
def test_every_help_has_a_description_and_one_example(path: str) -> None:
    parser = dict((" ".join(p), s) for p, s in ALL)[path]
    text = parser.format_help()
    assert parser.description and len(parser.description) > 40, path
    assert parser.description.split()[0] in text
    example = text.split("\nexample:\n" if "\nexample:\n" in text else "\nexamples:\n")
    assert len(example) == 2, text
    first = example[1].strip().splitlines()[0]
    assert first.startswith(f"rrr {path}"), first  # an example of this very command
    # the example parses (nothing in it is unknown to the command)
    args = build_parser().parse_args(shlex.split(first)[1:])
    assert callable(args.func)


#: the options of each rrr hil action, no more
HIL = {
    "bench": {"--text", "--scenario", "--duration", "--out", "--realtime", "--no-fifo",
              "--interface", "--channel", "--spin-us", "--can-log", "--no-can-log",
              "--no-figures", "--mcap", "--fd", "-q", "--quiet", "-v", "--verbose"},
    "controller": {"--text", "--scenario", "--duration", "--out", "--interface", "--connect",
                   "--channel", "--can-log", "--no-can-log", "--no-figures", "--mcap", "-q",
                   "--quiet", "-v", "--verbose"},
    "plant": {"--text", "--scenario", "--duration", "--out", "--interface", "--connect",
              "--channel", "--drop-commands-from", "--can-log", "--no-can-log", "--no-figures",
              "--mcap", "-q", "--quiet", "-v", "--verbose"},
    "export-reference": {"--text", "--scenario", "--duration", "--out", "-q", "--quiet", "-v",
                         "--verbose"},
    "canopen": {"--text", "--scenario", "--duration", "--out", "--node-ids", "--timeout",
                "--interface", "--channel", "--master", "--no-figures", "--realtime", "--no-fifo",
                "--spin-us", "--consumer-ms", "--rpdo-timeout", "-q", "--quiet", "-v",
                "--verbose"},
    "busload": {"--bitrate", "--fd", "--lockstep", "--dbc", "--profile", "--sync-period-ms",
                "-q", "--quiet", "-v", "--verbose"},
}


@pytest.mark.parametrize("action", list(HIL))
def test_each_hil_action_lists_only_its_own_options(action: str) -> None:
    parser = dict(ALL)[("hil", action)]
    assert options(parser) == HIL[action]
    text = parser.format_help()
    assert not re.search(r"'[a-z-]+' only", text)  # no "'busload' only" notes
    for other in set().union(*HIL.values()) - HIL[action]:
        assert f"{other} " not in text and f"{other}\n" not in text, other


def test_rrr_hil_bench_help_is_its_own() -> None:
    bench = subprocess.run([sys.executable, "-m", "rrr_robot", "hil", "bench", "--help"],
                           capture_output=True, text=True, check=True).stdout
    hil = subprocess.run([sys.executable, "-m", "rrr_robot", "hil", "--help"],
                         capture_output=True, text=True, check=True).stdout
    assert bench != hil and "--bitrate" not in bench and "--realtime" in bench
    assert "bench" in hil and "busload" in hil and "--realtime" not in hil


def test_another_actions_options_are_errors() -> None:
    proc = subprocess.run([sys.executable, "-m", "rrr_robot", "hil", "busload", "--realtime",
                           "--scenario", "nonsense", "--out", "/nonexistent/x"],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "unrecognized arguments: --realtime" in proc.stderr
    assert proc.stdout == ""


def test_fmus_help_names_the_three_fmus() -> None:
    text = dict(ALL)[("fmus",)].format_help()
    for fmu in ("rrr_plant", "rrr_controller", "rrr_reference"):
        assert fmu in text


def test_quiet_and_verbose_before_or_after_the_command() -> None:
    parser = build_parser()
    for argv, quiet, verbose in ((["writing"], False, False), (["-q", "writing"], True, False),
                                 (["writing", "-q"], True, False),
                                 (["-v", "run-ssp", "x.ssp", "--tool", "fmpy", "--out", "o",
                                   "-q"], True, True),
                                 (["hil", "bench", "-v"], False, True)):
        args = parser.parse_args(argv)
        assert (args.quiet, args.verbose) == (quiet, verbose), argv


def test_the_command_table_is_the_parsers_list_of_commands() -> None:
    from rrr_robot.cli.app import COMMANDS

    top = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    assert tuple(top[0].choices) == COMMANDS


@pytest.mark.parametrize("path", [" ".join(p) for p, _ in ALL])
def test_the_parser_of_one_command_is_the_whole_parsers(
        path: str, capsys: pytest.CaptureFixture[str]) -> None:
    """main() builds only the group of the command it is given (a faster start): its help, its
    usage line and its errors are those of the whole parser, word for word."""
    words = path.split()
    one = build_parser(words[0])
    whole = dict((" ".join(p), s) for p, s in ALL)[path]
    mine = dict((" ".join(p), s) for p, s in commands(one))[path]
    assert mine.format_help() == whole.format_help()
    assert one.format_usage() == build_parser().format_usage()
    messages = []
    for parser in (one, build_parser()):
        with pytest.raises(SystemExit):
            parser.parse_args([*words, "--no-such-option"])
        messages.append(capsys.readouterr().err)
    assert messages[0] == messages[1] and "error:" in messages[0]


def test_an_unknown_command_gets_the_whole_parser() -> None:
    from rrr_robot.cli.app import _command_of

    assert _command_of(["-q", "writing", "--out", "x"]) == "writing"
    assert _command_of(["-v", "hil", "bench"]) == "hil"
    assert _command_of(["--help"]) is None and _command_of([]) is None
    assert _command_of(["bogus", "writing"]) is None and _command_of(["--", "fmus"]) is None
    with pytest.raises(ValueError, match="unknown command"):
        build_parser("bogus")
