"""The shared readers of text data files: one-line errors naming the file, the line and the value."""

import pytest

from sessions.errors import DataFileError
from sessions.textfiles import finite_number, read_bytes


def test_finite_number_reads_numbers_and_names_what_is_wrong():
    assert finite_number("-1.5e-3", "f.csv: line 2", "v_V") == -1.5e-3
    with pytest.raises(DataFileError, match=r"^f.csv: line 7: v_V value 'abc' is not a number$"):
        finite_number("abc", "f.csv: line 7", "v_V")
    with pytest.raises(DataFileError, match=r"^f: line 3: HSat value 'nan' is not finite$"):
        finite_number("nan", "f: line 3", "HSat")


def test_read_bytes_says_why_a_file_cannot_be_read(tmp_path):
    (tmp_path / "a.txt").write_bytes(b"x,y\r\n")
    assert read_bytes(tmp_path / "a.txt", "a CSV file") == b"x,y\r\n"
    with pytest.raises(DataFileError, match="no such file"):
        read_bytes(tmp_path / "missing.csv", "a CSV file")
    with pytest.raises(DataFileError, match="is a directory, not a MicroMag file"):
        read_bytes(tmp_path, "a MicroMag file")
