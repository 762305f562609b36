"""The trial reader: every malformed input a clear error naming the file (exit 2 on the CLI, nothing
written), and the import features of real arm logs (motor-side logs through a transmission matrix,
torque constants and zero offsets; measured torque; dq differentiated when absent)."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import lcm
import numpy as np
import pytest

from sparc_quad.cli import main
from sparc_quad.gap.synth import synth
from sparc_quad.gap.trial import TrialError, load_lcm_log, load_trial, read_csv
from tests.gap_helpers import copy_trial, edit_meta


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("reader")
    res = synth(d, [], seed=1, n_trials=1, periods=1, period_s=1.0)
    return res["trials"][0]




def _lines(p: Path, fn) -> None:
    lines = p.read_text().splitlines()
    fn(lines)
    p.write_text("\n".join(lines) + "\n")


def _set(lines: list[str], row: int, col: int, text: str) -> None:
    f = lines[row].split(",")
    f[col] = text
    lines[row] = ",".join(f)


def _zero(lines):
    for i in range(1, len(lines)):
        f = lines[i].split(",")
        lines[i] = ",".join([f[0]] + ["0"] * (len(f) - 1))


def _dup(lines):
    lines[0] = lines[0].replace("q_q4", "q_q3", 1)


# case -> (make(p), where the message points: "csv" | "sidecar", regex)
def _case(kind: str, p: Path):
    side = p.with_suffix(".json")
    match kind:
        case "sidecar_number":
            side.write_text("3")
            return side, "must be a JSON object"
        case "sidecar_list":
            side.write_text("[1, 2]")
            return side, "must be a JSON object"
        case "rate_null":
            edit_meta(p, rate_hz=None)
            return side, "rate_hz must be a number"
        case "rate_nan":
            side.write_text(side.read_text().replace('"rate_hz": 1000.0', '"rate_hz": NaN'))
            return side, "rate_hz must be finite"
        case "rate_zero":
            edit_meta(p, rate_hz=0)
            return side, "rate_hz must be > 0"
        case "gravity_2":
            edit_meta(p, gravity=[0.0, -9.81])
            return side, "gravity must be a list of 3 numbers"
        case "period_zero":
            edit_meta(p, period_s=0.0)
            return side, "period_s must be > 0"
        case "period_negative":
            edit_meta(p, period_s=-1.5)
            return side, "period_s must be > 0"
        case "torque_kind":
            edit_meta(p, torque_kind="estimated")
            return side, "torque_kind must be one of"
        case "all_zero":
            _lines(p, _zero)
            return p, "every value except t is zero"
        case "non_utf8":
            p.write_bytes(p.read_bytes().replace(b"q_q2", b"q_q\xe92", 1))
            return p, "not UTF-8"
        case "sidecar_non_utf8":
            side.write_bytes(b'{"description": "\xff"}')
            return side, "not UTF-8"
        case "few_rows":
            _lines(p, lambda L: L.__delitem__(slice(11, None)))
            return p, "10 data rows; at least 16"
        case "duplicate_column":
            _lines(p, _dup)
            return p, "duplicate column 'q_q3'"
        case "huge_value":
            _lines(p, lambda L: _set(L, 7, 4, "1e300"))
            return p, r"row 7.*value 1e\+300 beyond"
        case "inf_value":
            _lines(p, lambda L: _set(L, 9, 5, "inf"))
            return p, "row 9.*non-finite"
        case "short_row":
            _lines(p, lambda L: L.__setitem__(12, ",".join(L[12].split(",")[:-2])))
            return p, "row 12.*fields, header has"
        case "text_value":
            _lines(p, lambda L: _set(L, 20, 3, "abc"))
            return p, "row 20.*not a number: 'abc'"
        case "directory":
            p.unlink()
            p.mkdir()
            return p, "is a directory"
        case "empty":
            p.write_text("")
            return p, "empty file"
    raise KeyError(kind)


CASES = ["sidecar_number", "sidecar_list", "rate_null", "rate_nan", "rate_zero", "gravity_2", "period_zero",
         "period_negative", "torque_kind", "all_zero", "non_utf8", "sidecar_non_utf8", "few_rows",
         "duplicate_column", "huge_value", "inf_value", "short_row", "text_value", "directory", "empty"]


@pytest.mark.parametrize("kind", CASES)
def test_bad_input_named_and_exit_2(good, tmp_path, capsys, kind):
    p = copy_trial(good, tmp_path, "trial")
    where, pattern = _case(kind, p)
    with pytest.raises(TrialError, match=pattern) as info:
        load_trial(p)
    assert str(info.value).startswith(str(where)), info.value
    out = tmp_path / "out"
    assert main(["gap", "run", str(p), "--out", str(out), "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert str(where) in err and "Traceback" not in err
    assert not out.exists()  # nothing half-written


def test_utf8_bom_accepted(good, tmp_path):
    p = copy_trial(good, tmp_path, "trial")
    p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    side = p.with_suffix(".json")
    side.write_bytes(b"\xef\xbb\xbf" + side.read_bytes())
    a, b = load_trial(good), load_trial(p)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.tau_cmd, b.tau_cmd)


def test_crlf_and_reader_agree_with_csv_module(good, tmp_path):
    p = copy_trial(good, tmp_path, "trial")
    p.write_bytes(p.read_bytes().replace(b"\n", b"\r\n"))
    header, data = read_csv(p)
    ref = np.genfromtxt(good, delimiter=",", names=None, skip_header=1)
    np.testing.assert_array_equal(data, ref)
    assert header[0] == "t"


def _lcm_file(path: Path, events: list[tuple[str, bytes]], bad_len_at: int | None = None) -> None:
    log = lcm.EventLog(str(path), "w", overwrite=True)
    for k, (ch, data) in enumerate(events):
        log.write_event(1000 * k, ch, data)
    log.close()
    if bad_len_at is not None:
        b = bytearray(path.read_bytes())
        pos = 0
        for _ in range(bad_len_at):  # walk to the event's header
            clen, dlen = struct.unpack(">ii", b[pos + 20:pos + 28])
            pos += 28 + clen + dlen
        b[pos + 24:pos + 28] = struct.pack(">I", 0x7FFFFFFF)
        path.write_bytes(bytes(b))


@pytest.mark.parametrize("where", ["first", "middle"])
def test_lcm_event_length_0x7fffffff_is_an_error_not_a_segfault(tmp_path, capsys, where):
    p = tmp_path / "bad.lcm"
    events = [("SOME_CHANNEL", b"\x00" * 100)] * 200
    _lcm_file(p, events, 0 if where == "first" else 50)
    with pytest.raises(TrialError, match="data length 2147483647") as info:
        load_lcm_log(p)
    assert str(info.value).startswith(str(p))
    assert main(["gap", "run", str(p), "--out", str(tmp_path / "out")]) == 2
    assert "bad.lcm" in capsys.readouterr().err


def test_lcm_bad_length_in_last_event_is_a_cut_tail(tmp_path, caplog):
    from sparc_quad.gap.lcm_scan import scan

    p = tmp_path / "tail.lcm"
    _lcm_file(p, [("SOME_CHANNEL", b"\x01" * 10)] * 30, 29)
    s = scan(p)
    assert s.events == 29 and s.problem and "event 30" in s.problem
    with pytest.raises(TrialError, match="no SPARC_SPINE_STATE events"):  # read 29 events, none a state
        load_lcm_log(p)


# ---- import features ---------------------------------------------------------------------------------
G = np.array([[1 / 9.0, 0.0, 0.0],  # q2: gear 9
              [0.0, -1 / 7.0, 0.0],  # q3: gear 7, motor mounted reversed
              [0.0, 1 / 7.0 * 0.3, 1 / 5.0]])  # q4: gear 5, coupled to motor 2 (a wrist)
KT = np.array([0.87, 0.5, 1.2])  # N*m/A
OFF = np.array([0.3, -1.0, 2.0])  # rad, motor side


def _motor_side(good: Path, tmp_path: Path, with_dq: bool = True) -> Path:
    tr = load_trial(good)
    q_m = tr.q @ np.linalg.inv(G).T + OFF
    dq_m = tr.dq @ np.linalg.inv(G).T
    cur = (tr.tau_cmd @ G) / KT  # tau_j = G^-T (kt i)  ->  kt i = G^T tau_j
    motors = ["m2", "m3", "m4"]
    cols = ["t", *(f"q_{m}" for m in motors)]
    blocks = [tr.t[:, None], q_m]
    if with_dq:
        cols += [f"dq_{m}" for m in motors]
        blocks.append(dq_m)
    cols += [f"tau_meas_{m}" for m in motors]
    blocks.append(cur)
    p = tmp_path / "motor.csv"
    np.savetxt(p, np.hstack(blocks), delimiter=",", header=",".join(cols), comments="", fmt="%.12g")
    meta = json.loads(good.with_suffix(".json").read_text())
    meta["urdf"] = str((good.parent / meta["urdf"]).resolve())
    meta.pop("plant")
    meta["torque_kind"] = "measured"
    meta["transmission"] = {"motors": motors, "motor_to_joint": G.tolist(),
                            "torque_constants_nm_per_a": KT.tolist(), "zero_offsets_rad": OFF.tolist()}
    p.with_suffix(".json").write_text(json.dumps(meta))
    return p


def test_motor_side_log_through_transmission(good, tmp_path):
    ref = load_trial(good)
    tr = load_trial(_motor_side(good, tmp_path))
    assert tr.torque_kind == "measured" and tr.tau_command is None
    np.testing.assert_allclose(tr.q, ref.q, atol=1e-9)
    np.testing.assert_allclose(tr.dq, ref.dq, atol=1e-8)
    np.testing.assert_allclose(tr.tau_cmd, ref.tau_cmd, atol=1e-8)
    np.testing.assert_allclose(tr.tau_meas, tr.tau_cmd)


def test_transmission_errors_named(good, tmp_path):
    p = _motor_side(good, tmp_path)
    side = p.with_suffix(".json")
    meta = json.loads(side.read_text())
    for change, pattern in (({"motor_to_joint": [[1, 0, 0], [0, 1, 0], [0, 0, 0]]}, "singular"),
                            ({"motor_to_joint": [[1, 0], [0, 1], [0, 0]]}, r"motor_to_joint\[0\]"),
                            ({"torque_constants_nm_per_a": [1, 0, 1]}, "zero entry"),
                            ({"zero_offsets_rad": [0, 0]}, "zero_offsets_rad must be a list of 3"),
                            ({"gear": 3}, "unknown key")):
        side.write_text(json.dumps({**meta, "transmission": {**meta["transmission"], **change}}))
        with pytest.raises(TrialError, match=pattern) as info:
            load_trial(p)
        assert str(info.value).startswith(str(side))
    side.write_text(json.dumps({**meta, "transmission": None, "torque_kind": "measured"}))
    with pytest.raises(TrialError, match=r"column 'q_m2'.*not a non-fixed joint"):
        load_trial(p)


def test_measured_kind_needs_measured_columns(good, tmp_path):
    p = copy_trial(good, tmp_path, "trial")
    edit_meta(p, torque_kind="measured")
    with pytest.raises(TrialError, match="required column missing") as info:
        load_trial(p)
    assert info.value.column == "tau_meas_q2"


def test_dq_differentiated_when_absent(good, tmp_path):
    ref = load_trial(good)
    tr = load_trial(_motor_side(good, tmp_path, with_dq=False))
    src = tr.meta["dq_source"]
    assert src["method"] == "savitzky_golay_derivative" and src["zero_phase"]
    inner = slice(50, -50)
    scale = np.sqrt(np.mean(ref.dq**2, axis=0))
    err = np.sqrt(np.mean((tr.dq[inner] - ref.dq[inner]) ** 2, axis=0)) / scale
    assert np.all(err < 0.02), err  # CyberGear-quantised q, 10 ms window: ~1 % of the RMS velocity
    p = tmp_path / "motor.csv"
    _lines(p, lambda L: L.__setitem__(0, L[0].replace("q_m4", "dq_m4")))
    with pytest.raises(TrialError, match="required column missing"):
        load_trial(p)
