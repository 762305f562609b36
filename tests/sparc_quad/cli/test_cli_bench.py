"""The command line: help explains units; a quick run writes its files."""

import json

import pytest

from sparc_quad.cli import build_parser, main


@pytest.mark.parametrize("cmd", [["bench", "static"], ["bench", "dynamic"], ["bench", "pd"], ["demo"]])
def test_help_states_units(cmd, capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args([*cmd, "--help"])
    text = capsys.readouterr().out
    assert "N/m" in text


def test_bench_static_quick_writes_outputs(tmp_path, capsys):
    assert main(["bench", "static", "--quick", "--kx", "400", "--out", str(tmp_path)]) == 0
    doc = json.loads((tmp_path / "static.json").read_text())
    assert doc["rows"][0]["k_cmd"] == 400.0
    assert (tmp_path / "static.png").stat().st_size > 10_000
    assert (tmp_path / "static.csv").read_text().startswith("k_cmd_n_m,x_m,f_x_n")
    assert "paper" in capsys.readouterr().out


def test_bad_number_list_is_a_clear_error(capsys):
    with pytest.raises(SystemExit):
        main(["bench", "static", "--kx", "300,abc"])
    assert "comma-separated numbers" in capsys.readouterr().err
