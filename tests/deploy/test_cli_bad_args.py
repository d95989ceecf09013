"""Every `zenav` command given bad arguments: exit status 2, the argument or file named, no traceback.

Numbers: every numeric option of every subcommand is walked from the parser itself (so a new option is
covered when it is added) and given NaN, Inf, a negative and a word. Files: each command that reads a
file is given a missing one and a corrupt one, as separate processes, as a user would run them.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import subprocess
import sys

import pytest

from common import argtypes
from deploy.cli import build_parser, main

ZENAV = [sys.executable, "-m", "deploy.cli"]
REPO = __import__("pathlib").Path(__file__).resolve().parents[2]
BAD = {
    argtypes.finite: ["nan", "inf", "-inf", "one"],
    argtypes.positive: ["nan", "inf", "0", "-1", "one"],
    argtypes.nonneg: ["nan", "-inf", "-0.5", "one"],
    argtypes.positive_int: ["0", "-3", "1.5", "nan"],
    argtypes.nonneg_int: ["-1", "2.5", "many"],
    argtypes.port: ["0", "70000", "-1", "http"],
}


def _leaves(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]  # noqa: SLF001
    if not subs:
        yield path, parser
    for a in subs:
        for name, sub in a.choices.items():
            yield from _leaves(sub, (*path, name))


def _numeric_options():
    out = []
    for path, parser in _leaves(build_parser()):
        for a in parser._actions:  # noqa: SLF001
            n = a.nargs if isinstance(a.nargs, int) else 1
            if a.type in (float, int):
                out.append((path, a.option_strings or [a.dest], "plain float / int", n))
            elif a.type in BAD:
                out.append((path, a.option_strings or [a.dest], a.type, n))
    return out


def test_no_command_takes_a_plain_float_or_int():
    """float('nan') and int('-5') pass argparse: every number goes through common.argtypes."""
    plain = [(" ".join(p), o[0]) for p, o, t, _ in _numeric_options() if t == "plain float / int"]
    assert not plain, f"options without a checking type: {plain}"
    assert len(_numeric_options()) >= 25  # the walk found the options


def _run_inprocess(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as e:
            code = e.code
    return code, err.getvalue()


def test_every_numeric_option_refuses_nan_inf_negatives_and_words():
    checked = 0
    options = _numeric_options()
    for path, opts, kind, nargs in options:
        for bad in BAD[kind]:
            if opts[0].startswith("-"):
                argv = [*path, opts[0], bad, *["0"] * (nargs - 1)] if nargs > 1 else [*path, f"{opts[0]}={bad}"]
            else:  # positional (goal x y yaw): the bad one first, then valid fillers
                n_pos = sum(1 for p, o, _, _ in options if p == path and not o[0].startswith("-"))
                argv = [*path, "--", bad, *["0"] * (n_pos - 1)]
            code, err = _run_inprocess(argv)
            where = f"zenav {' '.join(argv)}"
            assert code == 2, f"{where}: exit {code}\n{err}"
            assert "Traceback" not in err, f"{where}:\n{err}"
            if nargs > 1 and bad.startswith("-"):  # argparse takes '-inf' for an option: 'expected 3 arguments'
                continue
            assert bad in err and ("argument" in err), f"{where}: the message names neither value nor argument:\n{err}"
            checked += 1
    assert checked >= 100


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad_files")
    (d / "garbage.yaml").write_bytes(bytes(range(256)) * 4)
    (d / "not_a_mapping.yaml").write_text("- just\n- a list\n")
    (d / "broken.yaml").write_text("nodes:\n  move_base: {module: [unclosed\n")
    (d / "garbage.json5").write_bytes(b"{ this is : not json5 ]]]")
    (d / "garbage.bag").write_bytes(b"#ROSBAG V2.0\n" + bytes(range(200)) * 3)
    (d / "empty.txt").write_text("")
    (d / "trajectory.txt").write_text("# timestamp x y theta\n0.0 0 0 0\n1.0 0.5 0 0\n")
    return d


CASES = {
    "robot: missing config": (["robot", "--config", "{d}/missing.yaml"], "missing.yaml"),
    "robot: binary config": (["robot", "--config", "{d}/garbage.yaml"], "garbage.yaml"),
    "robot: config is a list": (["robot", "--config", "{d}/not_a_mapping.yaml"], "not_a_mapping.yaml"),
    "master: missing config": (["master", "--config", "{d}/missing.yaml"], "missing.yaml"),
    "master: broken yaml": (["master", "--config", "{d}/broken.yaml"], "broken.yaml"),
    "robot: missing world": (["robot", "--config", str(REPO / "robot_side/config/p3at_sim.yaml"), "--world",
                              "{d}/no_world.yaml"], "no_world.yaml"),
    "zenoh router: missing config": (["zenoh", "router", "--config", "{d}/missing.json5"], "missing.json5"),
    "zenoh router: corrupt config": (["zenoh", "router", "--config", "{d}/garbage.json5"], "garbage.json5"),
    "zenoh config: missing password file": (["zenoh", "config", "peer", "--user", "u", "--password-file",
                                             "{d}/missing.txt"], "missing.txt"),
    "slam run: corrupt bag": (["slam", "run", "{d}/garbage.bag", "--out", "{d}/out"], "garbage.bag"),
    "slam eval: missing trajectory": (["slam", "eval", "{d}/missing.txt", "--relations", "{d}/empty.txt"],
                                      "missing.txt"),
    "slam eval: empty relations": (["slam", "eval", "{d}/trajectory.txt", "--relations", "{d}/empty.txt"],
                                   "empty.txt"),
    "slam eval: text as trajectory": (["slam", "eval", "{d}/not_a_mapping.yaml", "--relations", "{d}/empty.txt"],
                                      "not_a_mapping.yaml:1"),
    "demo: unknown world": (["demo", "--world", "no_such_world", "--no-monitor"], "no_such_world"),
    "monitor: unwritable recording": (["monitor", "--save", "/proc/zenav/x.rrd", "--duration", "0.5"], "x.rrd"),
    "topic echo: bad topic name": (["topic", "echo", "sc*an", "--robot", "nobody"], "sc*an"),
}


def test_commands_given_missing_or_corrupt_files_name_them_in_one_line(bad_files):
    procs = {}
    for what, (argv, _) in CASES.items():
        argv = [a.format(d=bad_files) for a in argv]
        procs[what] = subprocess.Popen([*ZENAV, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                       cwd=REPO, env={**__import__("os").environ, "ZENAV_MULTICAST": "0"})
    failures = []
    for what, p in procs.items():
        try:
            out, err = p.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            p.kill()
            failures.append(f"{what}: still running after 120 s")
            continue
        name = CASES[what][1]
        if p.returncode != 2 or "Traceback" in err or name not in err:
            failures.append(f"{what}: exit {p.returncode}\n{err[-1500:]}")
    assert not failures, "\n\n".join(failures)
