"""Reading MicroMag 2900/3900 FORC data files (Princeton Measurements / Lake Shore VSM and AGM).

A file is a text header, then the data: blank-line separated *segments*
of ``field,moment`` lines.  This module reads the file as written -- the
header's settings, each segment with the line it starts on -- and checks
its FORC structure; what the measurement means for a Preisach model
(the input history, the times) is :mod:`sessions.forc`.

Two header styles exist in practice, both read here:

* **Series 0015** (older software): a title, ``Key: value`` lines about the
  instrument, a date line and a description line, then two blocks of
  ``Key = value`` lines (the script: ``HSat``, ``HCal``, ``NCrv``,
  ``PauseNtl``, ...; then the measurement: ``Elapsed time``, ``NData``, ...).
* **Series 0016** (``Series 0016.002``): a title and the measurement kind,
  then named sections (``INSTRUMENT``, ``SETTINGS``, ``MEASUREMENT``,
  ``SCRIPT``, ...) of ``Key<spaces>value`` lines, then a block naming the
  data columns and their units (``Field  Moment`` / ``(T)  (Am²)``), and a
  last line ``MicroMag 2900/3900 Data File ends``.

Files are Latin-1 text (the ``²`` of the units line), usually with CRLF
line endings; any line ending is accepted.

FORC structure: before every curve the instrument measures one point at
the calibration field ``HCal`` (a drift monitor), so the segments alternate
one-point calibration segments and curves, each curve starting at its
reversal field and rising.  Every problem is a :class:`DataFileError` naming
the file and the line.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import DataFileError
from .textfiles import finite_number, read_bytes

#: The end marker of a Series 0016 file.
END_MARKER = "MicroMag 2900/3900 Data File ends"

_TITLE = re.compile(r"MicroMag\s+2900/3900\s+Data\s+File(?:\s*\(Series\s+([0-9.]+)\))?\s*(.*)$", re.I)
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_DATA_LINE = re.compile(rf"^\s*{_NUMBER}\s*,")
_EQUALS = re.compile(r"^([A-Za-z][^=]*?)\s*=\s*(.*?)\s*$")
_COLON = re.compile(r"^([A-Za-z][^:=]*?)\s*:\s*(.*?)\s*$")
_COLUMNS = re.compile(r"^(\S.*?)\s{2,}(\S.*?)\s*$")
_SECTION = re.compile(r"^[A-Z][A-Z0-9 _-]*$")

#: Canonical setting -> the names it has in either header style.
SETTING_NAMES: dict[str, tuple[str, ...]] = {
    "averaging_time": ("Averaging time",),
    "h_sat": ("HSat",),
    "h_cal": ("HCal",),
    "h_ncr": ("HNcr",),
    "hb1": ("Hb1",),
    "hb2": ("Hb2",),
    "hc1": ("Hc1",),
    "hc2": ("Hc2",),
    "n_forc": ("NForc", "NCrv"),
    "pause_calibration": ("PauseCal",),
    "pause_saturation": ("PauseSat",),
    "pause_reversal": ("PauseRvrsl", "PauseNtl"),
    "slew_rate": ("SlewRate",),
    "elapsed_time": ("Elapsed time",),
    "n_data": ("Number of data", "NData"),
    "n_segments": ("Number of segments",),
    "units": ("Units of measure",),
    "sweep_mode": ("Sweep mode",),
    "pause_increment": ("Pause after sweep increment",),
    "hysteresis_loop": ("Includes hysteresis loop?",),
    "measured_on": ("Measured on",),
    "description": ("Description",),
}

#: Section order in which a setting is looked up (Series 0016 repeats
#: ``Averaging time`` in SETTINGS and SCRIPT: the script's governs the FORCs).
_LOOKUP_ORDER = ("SCRIPT", "MEASUREMENT", "SETTINGS", "INSTRUMENT", "SAMPLE", "PROCESSING")

#: ``Units of measure`` -> (field unit, moment unit), for headers without a units line.
UNIT_SYSTEMS = {"hybrid si": ("T", "A m^2"), "cgs": ("Oe", "emu")}

_UNIT_SPELLINGS = {
    "t": "T", "mt": "mT", "oe": "Oe", "a/m": "A/m", "emu": "emu",
    "am2": "A m^2", "am²": "A m^2", "a·m²": "A m^2", "am^2": "A m^2", "a m^2": "A m^2",
}


@dataclass(frozen=True)
class HeaderValue:
    """One header entry as written: its text and its line (1-based)."""

    text: str
    line: int


@dataclass(frozen=True, eq=False)
class Segment:
    """A blank-line separated run of data lines: ``field`` and ``moment`` ``(m,)``;
    ``line`` is the file line of its first point (1-based)."""

    line: int
    field: np.ndarray
    moment: np.ndarray

    def __len__(self) -> int:
        return int(self.field.size)


@dataclass(frozen=True, eq=False)
class MicroMagHeader:
    """The header: its style, title and every entry by section.

    ``style`` is ``"0015"`` or ``"0016"``; ``series`` the version in the
    title (``"0016.002"``); ``kind`` the measurement kind
    (``First-order reversal curves``); ``sections`` maps a section name
    (Series 0015: ``INSTRUMENT``, ``SCRIPT``, ``MEASUREMENT`` by position)
    to its entries; ``field_unit``/``moment_unit`` the data's units.
    """

    style: str
    series: str
    kind: str
    sections: dict[str, dict[str, HeaderValue]]
    field_unit: str
    moment_unit: str
    end_line: int

    def entry(self, setting: str) -> HeaderValue | None:
        """The entry of a canonical setting (see :data:`SETTING_NAMES`), or ``None``."""
        names = SETTING_NAMES[setting]
        order = [s for s in _LOOKUP_ORDER if s in self.sections] + [
            s for s in self.sections if s not in _LOOKUP_ORDER
        ]
        for section in order:
            for name in names:
                if name in self.sections[section]:
                    return self.sections[section][name]
        return None

    def number(self, setting: str, path: Path, required: bool = False) -> float | None:
        """A numeric setting; ``None`` when absent or ``N/A`` (an error if ``required``)."""
        entry = self.entry(setting)
        if entry is None or entry.text.upper() in ("N/A", ""):
            if required:
                names = " or ".join(repr(n) for n in SETTING_NAMES[setting])
                where = "is missing" if entry is None else f"is N/A (line {entry.line})"
                raise DataFileError(f"{path}: the header's {names} {where}; it is needed to import the FORCs")
            return None
        return finite_number(entry.text.strip().strip('"'), f"{path}: line {entry.line}", SETTING_NAMES[setting][0])

    def text(self, setting: str) -> str | None:
        entry = self.entry(setting)
        return None if entry is None else entry.text.strip().strip('"')

    def as_dict(self) -> dict[str, dict[str, str]]:
        """Every entry as text, by section (kept with an imported session)."""
        return {s: {k: v.text for k, v in entries.items()} for s, entries in self.sections.items()}


@dataclass(frozen=True, eq=False)
class MicroMagFile:
    """A MicroMag FORC file as written: header and data segments, in file order."""

    path: Path
    header: MicroMagHeader
    segments: tuple[Segment, ...]
    end_marker: bool
    n_lines: int


@dataclass(frozen=True, eq=False)
class ForcFile:
    """The FORC structure of a file: one calibration point before every curve.

    ``calibration`` ``[k]`` is the one-point segment measured at ``HCal``
    before ``curves[k]``; curves are numbered from 0 in file order.
    """

    source: MicroMagFile
    calibration: tuple[Segment, ...]
    curves: tuple[Segment, ...]

    @property
    def header(self) -> MicroMagHeader:
        return self.source.header

    @property
    def path(self) -> Path:
        return self.source.path

    @property
    def n_points(self) -> int:
        """Measured curve points (calibration points not included)."""
        return sum(len(c) for c in self.curves)


# ---------------------------------------------------------------- reading
def read_lines(path: Path) -> list[str]:
    """The file's lines (Latin-1, any line ending), or :class:`DataFileError` saying why not."""
    raw = read_bytes(path, "a MicroMag file")
    if not raw.strip():
        raise DataFileError(f"{path}: empty file, not a MicroMag data file")
    if b"\x00" in raw[:4096]:
        raise DataFileError(f"{path}: a binary file, not a MicroMag text data file")
    lines = re.split(r"\r\n|\r|\n", raw.decode("latin-1"))
    if lines and lines[-1] == "":
        lines.pop()
    return lines


def _unit(token: str) -> str:
    t = token.strip().strip("()").replace("Â", "").strip()
    return _UNIT_SPELLINGS.get(t.lower(), t)


def _title(path: Path, lines: list[str]) -> tuple[str, str, int]:
    """(series, kind, index of the first header line after the title)."""
    m = _TITLE.match(lines[0].strip())
    if not m:
        raise DataFileError(
            f"{path}: line 1: not a MicroMag 2900/3900 data file (expected 'MicroMag 2900/3900 Data File', "
            f"got {lines[0].strip()[:60]!r})"
        )
    series, rest = m.group(1) or "", m.group(2).strip()
    if rest:
        return series, rest, 1
    if len(lines) < 2:
        raise DataFileError(f"{path}: truncated after line 1 (no measurement kind, no header)")
    return series, lines[1].strip(), 2


def _data_start(lines: list[str], first: int) -> int:
    for k in range(first, len(lines)):
        if _DATA_LINE.match(lines[k]):
            return k
    return len(lines)


def _header_0016(path: Path, lines: list[str], first: int, end: int):
    sections: dict[str, dict[str, HeaderValue]] = {}
    current: dict[str, HeaderValue] | None = None
    columns: list[str] = []
    for k in range(first, end):
        line = lines[k]
        if not line.strip():
            current = None
            continue
        if line[0].isspace():  # the column block: names, then units
            columns.append(line.strip())
            current = None
            continue
        if columns:
            raise DataFileError(f"{path}: line {k + 1}: header text after the data columns were named")
        if current is None and _SECTION.match(line.strip()) and not _COLUMNS.match(line):
            current = sections.setdefault(line.strip(), {})
            continue
        m = _COLUMNS.match(line)
        if current is None or not m:
            where = "outside a section" if current is None else "expected 'name   value'"
            raise DataFileError(f"{path}: line {k + 1}: unexpected header line {line.strip()[:60]!r} ({where})")
        current[m.group(1).strip()] = HeaderValue(m.group(2), k + 1)
    units = ("", "")
    if len(columns) >= 2:
        names = columns[-2].split()
        tokens = re.findall(r"\(([^)]*)\)", columns[-1])
        if len(tokens) == len(names):
            by_name = {n.lower(): _unit(u) for n, u in zip(names, tokens)}
            units = (by_name.get("field", ""), by_name.get("moment", ""))
    return sections, units


def _header_0015(path: Path, lines: list[str], first: int, end: int):
    sections: dict[str, dict[str, HeaderValue]] = {"INSTRUMENT": {}, "MEASUREMENT": {}, "SCRIPT": {}}
    blocks = 0  # '=' blocks seen: the first is the script, the second the measurement
    in_block = False
    free: list[HeaderValue] = []
    for k in range(first, end):
        line = lines[k].strip()
        if not line:
            if in_block:
                blocks += 1
                in_block = False
            continue
        m = _EQUALS.match(line)
        if m:
            in_block = True
            target = sections["SCRIPT"] if blocks == 0 else sections["MEASUREMENT"]
            target[m.group(1).strip()] = HeaderValue(m.group(2), k + 1)
            continue
        if blocks or in_block:
            raise DataFileError(f"{path}: line {k + 1}: expected 'Key = value', got {line[:60]!r}")
        m = _COLON.match(line)
        if m and not free:
            sections["INSTRUMENT"][m.group(1).strip()] = HeaderValue(m.group(2), k + 1)
        else:
            free.append(HeaderValue(line, k + 1))
    # the free lines after the instrument block: the date, then the description
    for name, value in zip(("Measured on", "Description"), free):
        sections["MEASUREMENT"].setdefault(name, value)
    return sections, ("", "")


def _units(path: Path, style: str, sections, from_columns: tuple[str, str]) -> tuple[str, str]:
    if all(from_columns):
        return from_columns
    header = MicroMagHeader(style, "", "", sections, "", "", 0)
    entry = header.entry("units")
    system = (entry.text.strip().lower() if entry else "")
    if system in UNIT_SYSTEMS:
        return UNIT_SYSTEMS[system]
    where = f"line {entry.line}: " if entry else ""
    raise DataFileError(
        f"{path}: {where}units of measure {entry.text.strip() if entry else '(none given)'!r} are not understood; "
        "this reader knows 'Hybrid SI' (T, A m^2) and 'cgs' (Oe, emu)"
    )


def _segments(path: Path, lines: list[str], start: int) -> tuple[list[Segment], bool]:
    segments: list[Segment] = []
    rows: list[tuple[float, float]] = []
    first = 0
    end_marker = False

    def close() -> None:
        if rows:
            a = np.array(rows, dtype=float)
            segments.append(Segment(first, a[:, 0].copy(), a[:, 1].copy()))
            rows.clear()

    for k in range(start, len(lines)):
        line = lines[k].strip()
        if not line:
            close()
            continue
        if line.startswith(END_MARKER):
            close()
            end_marker = True
            extra = [j for j in range(k + 1, len(lines)) if lines[j].strip()]
            if extra:
                raise DataFileError(f"{path}: line {extra[0] + 1}: text after the end marker {END_MARKER!r}")
            break
        cells = line.split(",")
        if len(cells) < 2:
            raise DataFileError(f"{path}: line {k + 1}: expected 'field,moment', got {line[:60]!r}")
        try:
            h, m = float(cells[0]), float(cells[1])
        except ValueError:
            raise DataFileError(
                f"{path}: line {k + 1}: expected two numbers 'field,moment', got {line[:60]!r}"
                + (" (the file may be truncated here)" if k == len(lines) - 1 else "")
            ) from None
        if not (np.isfinite(h) and np.isfinite(m)):
            raise DataFileError(f"{path}: line {k + 1}: non-finite value in {line[:60]!r}")
        if not rows:
            first = k + 1
        rows.append((h, m))
    close()
    return segments, end_marker


def read_micromag(path: str | os.PathLike) -> MicroMagFile:
    """Read a MicroMag 2900/3900 data file in either header style (no FORC checks yet)."""
    path = Path(path)
    lines = read_lines(path)
    series, kind, first = _title(path, lines)
    start = _data_start(lines, first)
    if series.startswith("0015"):
        style = "0015"
    elif series:
        style = "0016"
    else:  # no series in the title: tell the styles apart by their lines
        style = "0015" if any(_EQUALS.match(ln.strip()) for ln in lines[first:start]) else "0016"
    parse = _header_0015 if style == "0015" else _header_0016
    sections, column_units = parse(path, lines, first, start)
    field_unit, moment_unit = _units(path, style, sections, column_units)
    header = MicroMagHeader(style, series, kind, sections, field_unit, moment_unit, start)
    if start == len(lines):
        raise DataFileError(f"{path}: no data after the header (the file ends at line {len(lines)})")
    segments, end_marker = _segments(path, lines, start)
    return MicroMagFile(path, header, tuple(segments), end_marker, len(lines))


# ---------------------------------------------------------------- FORC structure
def _count(header: MicroMagHeader, setting: str, path: Path) -> int | None:
    value = header.number(setting, path)
    if value is None:
        return None
    if value != int(value) or value < 0:
        entry = header.entry(setting)
        raise DataFileError(f"{path}: line {entry.line}: {SETTING_NAMES[setting][0]} {entry.text!r} is not a count")
    return int(value)


def forc_structure(data: MicroMagFile) -> ForcFile:
    """Split the segments into calibration points and curves, checking the FORC protocol.

    Checks: the file is a FORC measurement (its kind says so, no hysteresis
    loop segment); segments alternate a one-point calibration segment near
    ``HCal`` and a curve whose field does not fall; the counts the header
    announces (curves, data points, segments) are all there, so a truncated
    file is an error naming where it ends.
    """
    path, header = data.path, data.header
    if "first-order reversal" not in header.kind.lower():
        raise DataFileError(
            f"{path}: line 2: the file holds {header.kind!r}, not first-order reversal curves"
        )
    loop = header.text("hysteresis_loop")
    if loop is not None and loop.lower().startswith("y"):
        raise DataFileError(
            f"{path}: line {header.entry('hysteresis_loop').line}: files that include a hysteresis loop "
            "before the FORCs are not supported"
        )
    h_sat = header.number("h_sat", path, required=True)
    h_cal = header.number("h_cal", path, required=True)
    h_ncr = header.number("h_ncr", path) or 0.0
    tolerance = 0.02 * abs(h_sat)
    n_forc, n_data = _count(header, "n_forc", path), _count(header, "n_data", path)
    n_segments = _count(header, "n_segments", path)
    segs = data.segments
    where = f"the file ends at line {data.n_lines}"
    calibration, curves = [], []
    for k, seg in enumerate(segs):
        if k % 2 == 0:
            if len(seg) != 1:
                raise DataFileError(
                    f"{path}: line {seg.line}: expected the one-point calibration measurement at HCal before "
                    f"curve {k // 2}, found a segment of {len(seg)} points (lines {seg.line}-{seg.line + len(seg) - 1})"
                )
            if abs(seg.field[0] - h_cal) > tolerance:
                raise DataFileError(
                    f"{path}: line {seg.line}: calibration point at {seg.field[0]:g} {header.field_unit}, "
                    f"far from HCal = {h_cal:g} {header.field_unit}"
                )
            calibration.append(seg)
            continue
        falls = np.flatnonzero(np.diff(seg.field) < -max(0.5 * h_ncr, 0.0))
        if falls.size:
            j = int(falls[0])
            raise DataFileError(
                f"{path}: line {seg.line + j + 1}: the field falls from {seg.field[j]:g} to {seg.field[j + 1]:g} "
                f"{header.field_unit} within curve {k // 2}; a first-order reversal curve only rises"
            )
        if seg.field[0] >= h_cal:
            raise DataFileError(
                f"{path}: line {seg.line}: curve {k // 2} starts at {seg.field[0]:g} {header.field_unit}, "
                f"not below the calibration field HCal = {h_cal:g}"
            )
        curves.append(seg)
    total = sum(len(s) for s in segs)
    if n_data is not None and total < n_data:
        raise DataFileError(
            f"{path}: truncated: the header (line {header.entry('n_data').line}) announces {n_data} data points, "
            f"the file holds {total} and {where}"
        )
    if n_data is not None and total > n_data:
        raise DataFileError(
            f"{path}: {total} data points, more than the {n_data} the header announces "
            f"(line {header.entry('n_data').line})"
        )
    if header.style == "0016" and not data.end_marker:
        raise DataFileError(f"{path}: truncated: no end marker {END_MARKER!r}; {where}")
    if len(calibration) > len(curves):
        raise DataFileError(
            f"{path}: truncated: the calibration point on line {calibration[-1].line} is not followed by its curve; "
            f"{where}"
        )
    if not curves:
        raise DataFileError(f"{path}: no curves in the file")
    if n_forc is not None and len(curves) != n_forc:
        what = "truncated: " if len(curves) < n_forc else ""
        raise DataFileError(
            f"{path}: {what}the header (line {header.entry('n_forc').line}) announces {n_forc} curves, "
            f"the file holds {len(curves)}; {where}"
        )
    if n_segments is not None and len(segs) != n_segments:
        raise DataFileError(
            f"{path}: the header (line {header.entry('n_segments').line}) announces {n_segments} segments, "
            f"the file holds {len(segs)}; {where}"
        )
    return ForcFile(data, tuple(calibration), tuple(curves))


def read_forc(path: str | os.PathLike) -> ForcFile:
    """Read a MicroMag FORC file and check its structure (see :func:`forc_structure`)."""
    return forc_structure(read_micromag(path))
