"""Malformed logs never crash ``unidyn identify``, and the message points at the fault.

``unidyn identify FILE --out DIR`` is called in-process (``unidyn.cli.main``) on
broken CSV files (bytes that are not text, cells that are not numbers, short
rows, NaN, time going back, missing columns, huge fields) and with bad
``--columns``. Every call must exit with status 2 and one ``unidyn: error:``
line that names the file and the line and column (or the --columns key) at
fault, stays short whatever the input's size, and writes no results. Then a
seeded random corruption of one cell of a valid log, many times over.
"""

from __future__ import annotations

import numpy as np
import pytest

from unidyn.cli import main

pytestmark = pytest.mark.reliability

HEADER = "t,u_ref,w_ref,u,w,comment"


def valid_rows(n=60):
    rng = np.random.default_rng(0)
    t = np.arange(n) * 0.1
    ur = 0.3 + 0.1 * np.sin(t)
    wr = 0.5 * np.sin(0.7 * t)
    u = ur + 0.01 * rng.standard_normal(n)
    w = wr + 0.01 * rng.standard_normal(n)
    return [[f"{a:.4f}" for a in row] + ["x"] for row in zip(t, ur, wr, u, w)]


def csv_text(rows, header=HEADER):
    return header + "\n" + "\n".join(",".join(r) for r in rows) + "\n"


def run(capsys, tmp_path, content, *extra, name="log.csv"):
    p = tmp_path / name
    p.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    out = tmp_path / "out"
    code = main(["identify", str(p), "--out", str(out), *extra])
    o, err = capsys.readouterr()
    return code, err, out


def check(code, err, out, *words):
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("unidyn: error: "), err
    assert "Traceback" not in err and len(lines[0]) < 600, err[:800]
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not (out / "theta.json").exists()


def with_cell(line, col, value):
    rows = valid_rows()
    rows[line - 2][col] = value
    return csv_text(rows)


CASES = {
    "empty": ("", ["log.csv", "no header row"]),
    "comments only": ("# a\n# b\n", ["log.csv", "no header row"]),
    "header only": (HEADER + "\n", ["has 0 rows", "at least 20"]),
    "latin-1 C1 byte": (csv_text(valid_rows()).encode().replace(b"\n0.5000,",
                                                                 b"\n0.5000\x81\x8d,", 1),
                        ["log.csv line 7", "not text"]),
    "NUL byte": (csv_text(valid_rows()).encode().replace(b"\n1.0000,", b"\n1.0\x00000,", 1),
                 ["log.csv line 12", "NUL byte", "not text"]),
    "text in a cell": (with_cell(9, 3, "abc"), ["log.csv line 9, column 'u': 'abc'"]),
    "empty cell": (with_cell(20, 4, ""), ["log.csv line 20, column 'w': ''"]),
    "decimal comma": (with_cell(5, 1, "0,3"), ["log.csv line 5"]),
    "huge cell": (with_cell(30, 2, "9" * 100_000 + "x"), ["log.csv line 30, column 'w_ref'"]),
    "nan": (with_cell(11, 3, "nan"), ["'u'", "NaN/inf", "sample 9"]),
    "time going back": (with_cell(15, 0, "0.1"), ["'t'", "going back at sample 13"]),
    "short row": (csv_text(valid_rows()[:10]) + "1.0,0.3\n" + csv_text(valid_rows()[11:], ""),
                  ["log.csv line 12 has 2 field(s)"]),
    "missing column": (csv_text([r[:4] + ["x"] for r in valid_rows()],
                                "t,u_ref,w_ref,u,comment"), ["'w'", "--columns"]),
    "huge header": (csv_text(valid_rows(), "t,u_ref,w_ref,u," + "W" * 100_000 + ",comment"),
                    ["'w'", "--columns"]),
    "utf-16 bom, bad": (b"\xff\xfe" + "t,u_ref".encode("utf-16-le") + b"\x00\xd8",
                        ["log.csv line 1", "UTF-16"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_malformed_log_is_one_line_naming_the_place(tmp_path, capsys, case):
    content, words = CASES[case]
    check(*run(capsys, tmp_path, content), *words)


@pytest.mark.parametrize("spec,words", [
    ("", ["--columns"]),
    ("t", ["--columns", "'t'"]),
    ("time=t", ["--columns", "'time'"]),
    ("t=,u=v", ["--columns", "'t='"]),
    ("u=" + "v" * 5000, ["missing column", "--columns"]),
    ("x" * 5000 + "=t", ["--columns", "unknown name"]),
])
def test_bad_columns_name_the_key(tmp_path, capsys, spec, words):
    check(*run(capsys, tmp_path, csv_text(valid_rows()), "--columns", spec), *words)


def test_a_folder_or_a_missing_file_is_named(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["identify", str(tmp_path), "--out", str(out)]) == 2
    check(2, capsys.readouterr()[1], out, str(tmp_path), "folder")
    assert main(["identify", str(tmp_path / "none.csv"), "--out", str(out)]) == 2
    check(2, capsys.readouterr()[1], out, "none.csv")


JUNK = ["", " ", "abc", "1e999x", "--", "0x1F", "1,5", "NaN?", "∞", "é", "1.0.0", "'1'", "+-1",
        "z" * 3000]


def test_random_corruptions_name_line_and_column(tmp_path, capsys):
    rng = np.random.default_rng(12345)
    names = HEADER.split(",")
    for i in range(60):
        line = int(rng.integers(2, 62))
        col = int(rng.integers(0, 5))
        junk = JUNK[int(rng.integers(len(JUNK)))]
        code, err, out = run(capsys, tmp_path, with_cell(line, col, junk), name=f"f{i}.csv")
        if "," in junk:    # one field more than the header: the line is named
            check(code, err, out, f"f{i}.csv line {line} has 7 fields")
        else:
            check(code, err, out, f"f{i}.csv line {line}, column '{names[col]}'")
