"""Every numeric option is checked where it is parsed: a bad value is argparse's usage line naming the
option and exit 2, never a traceback, a silent spin or a silently disabled feature."""

from __future__ import annotations

import argparse

import pytest

from sparc_quad.cli import main
from sparc_quad.cli.args import in_range, number_list, positive_float

BAD = [
    (["spine-node", "--rate", "nan"], "--rate"),
    (["spine-node", "--rate", "0"], "--rate"),
    (["spine-node", "--rate", "-1"], "--rate"),
    (["spine-node", "--rate", "inf"], "--rate"),
    (["spine-node", "--soft-start", "nan"], "--soft-start"),
    (["spine-node", "--state-every", "0"], "--state-every"),
    (["spine-node", "--duration", "-1"], "--duration"),
    (["spine-node", "--can-bitrate", "0"], "--can-bitrate"),
    (["spine-node", "--experiment", "static", "--period", "0"], "--period"),
    (["spine-node", "--experiment", "static", "--kx", "-5"], "--kx"),
    (["bench-robot", "--period", "0"], "--period"),
    (["spine-cmd", "--kth", "nan"], "--kth"),
    (["spine-cmd", "--x-d", "0.27", "nan", "0"], "--x-d"),
    (["spine-echo", "--timeout", "-1"], "--timeout"),
    (["gap", "run", "t.csv", "--out", "o", "--cutoff", "0"], "--cutoff"),
    (["gap", "run", "t.csv", "--out", "o", "--window", "nan"], "--window"),
    (["bound", "--kx", "-1"], "--kx"),
    (["bound", "--dth", "inf"], "--dth"),
    (["bound", "--frequency", "-4"], "--frequency"),
    (["bound", "--duty", "2"], "--duty"),
    (["bound", "--duty", "0"], "--duty"),
    (["bound", "--imu-delay", "-5"], "--imu-delay"),
    (["bound", "--imu-delay", "1.5"], "--imu-delay"),
    (["bound", "--duration", "-1"], "--duration"),
    (["bound", "--duration", "0"], "--duration"),
    (["bound", "--host", "nosuch"], "--host"),
    (["bound", "--slope", "2"], "--slope"),
    (["bench", "static", "--kx", "300,-1"], "--kx"),
    (["bench", "dynamic", "--dx", "0,nan"], "--dx"),
    (["bench", "dynamic", "--trials", "0"], "--trials"),
    (["motors", "scan", "--timeout", "0"], "--timeout"),
    (["motors", "set-id", "--new-id", "200"], "--new-id"),
    (["motors", "scan", "--host-id", "0x1FF"], "--host-id"),
]


@pytest.mark.parametrize(("argv", "option"), BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_number_is_exit_2_naming_the_option(argv, option, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert f"argument {option}" in err and "Traceback" not in err, err


def test_types_accept_the_edges_they_name():
    assert positive_float("1e-9") == 1e-9
    assert in_range(0.0, 1.0)("1") == 1.0
    with pytest.raises(argparse.ArgumentTypeError, match=r"\(0.0, 1.0\)"):
        in_range(0.0, 1.0, lo_open=True, hi_open=True)("1")
    assert number_list()("300, 400") == (300.0, 400.0)
    with pytest.raises(argparse.ArgumentTypeError):
        number_list()("300,,400")


def test_gain_defaults_come_from_params():
    from sparc_quad.cli import build_parser
    from spine_module import params as P

    args = build_parser().parse_args(["spine-cmd"])
    assert (args.kx, args.kz, args.kth) == tuple(P.K_DEFAULT)
    assert (args.dx, args.dz, args.dth) == tuple(P.D_DEFAULT)
    args = build_parser().parse_args(["bench", "static"])
    assert args.kx == P.BENCH_STATIC_K_X_N_M and args.dx == P.BENCH_QUASI_STATIC_D_X_N_S_M
