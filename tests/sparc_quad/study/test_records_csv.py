"""trials.csv is a function of the records on disk: a fresh record and its cached copy give the same bytes."""

import math

import numpy as np

from sparc_quad.study.records import read_record, write_csv, write_record


def _fresh(i: int) -> dict:
    return {
        "hash": f"h{i}",
        "config": {"gait": "bound", "spine": "sparc", "speed": 0.5 + i, "seed": i},
        "status": "ok",
        "error": None,
        "wall_s": 1.25 + i,
        "metrics": {
            "fell": False,
            "cot": float("nan"),  # a metric this trial could not compute
            "speed_m_s": np.float64(0.1 * (i + 1)),
            "peak": {"torque_nm": np.float32(2.5), "inf": math.inf},
            "pair": (1, 2.0),
            "strides": [{"t": 0.1}],
        },
    }


def test_fresh_and_cached_records_give_identical_csv(tmp_path):
    fresh = [_fresh(i) for i in range(3)]
    for rec in fresh:
        write_record(tmp_path / "trials", rec)
    cached = [read_record(tmp_path / "trials" / f"{r['hash']}.json") for r in fresh]
    a = write_csv(tmp_path / "a.csv", fresh).read_bytes()
    b = write_csv(tmp_path / "b.csv", cached).read_bytes()
    mixed = write_csv(tmp_path / "c.csv", [fresh[0], cached[1], fresh[2]]).read_bytes()
    assert a == b == mixed
    assert b"nan" not in a.lower() and b"inf" not in a.split(b"\n", 1)[1].lower()


def test_a_committed_gzip_record_is_found_by_its_plain_name(tmp_path):
    import gzip
    import json

    from sparc_quad.study.records import read_record

    rec = {"hash": "abc", "config": {"seed": 0}, "status": "ok"}
    (tmp_path / "abc.json.gz").write_bytes(gzip.compress(json.dumps(rec).encode()))
    assert read_record(tmp_path / "abc.json") == rec
    assert read_record(tmp_path / "missing.json") is None
