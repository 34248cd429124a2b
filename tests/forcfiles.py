"""Hand-written MicroMag FORC files for the tests, in both header styles.

The layouts follow public files of the instrument: Series 0016 (a title and
the measurement kind, named sections of ``Key<spaces>value`` lines with the
value from column 32, a column block ``Field Moment`` / ``(T) (Am²)``, data
in engineering notation, the end marker), CRLF line endings and a Latin-1
``²``; Series 0015 (``Key: value`` instrument lines, a date and a
description, two blocks of ``Key = value`` lines, ``NCrv``/``PauseNtl``/
``NData``, scientific notation, no end marker).

The moments come from a *relay ensemble* in closed form -- after positive
saturation and a descent to ``r``, a relay ``(alpha, beta)`` is down exactly
when ``beta > r`` and ``alpha > x`` -- so the tests can compare against a
simulation that never saw the protocol.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

#: The repository's root directory.
REPO = Path(__file__).resolve().parents[1]
#: The shared real FORC measurement: ``../shared/data/forc/`` relative to the repository root, in CI and in
#: every clone (never an absolute path: that made the real-data tests skip silently everywhere else).
SHARED_FORC = REPO.parent / "shared" / "data" / "forc" / "MD00-2361.forc"


def shared_forc() -> Path:
    """The shared measurement; a test that needs it fails, never skips, when it is not there."""
    if not SHARED_FORC.is_file():
        pytest.fail(f"the shared FORC measurement is missing: expected {SHARED_FORC} "
                    "(../shared/data/forc/MD00-2361.forc beside the repository)")
    return SHARED_FORC


def engineering(x: float) -> str:
    """MicroMag's Series 0016 number: 7 significant digits, exponent a multiple of 3, sign."""
    if x == 0:
        return " 0.000000E+00"
    e = int(np.floor(np.log10(abs(x)) / 3) * 3)
    m = x / 10.0**e
    if round(abs(m), 7 - len(str(int(abs(m))))) >= 1000:
        e += 3
        m = x / 10.0**e
    digits = 7 - len(str(int(abs(m))))
    return f"{m:+.{digits}f}E{e:+03d}"


def printed(x) -> np.ndarray:
    """``x`` as a file holds it: rounded to 7 significant digits (exact when the digits suffice)."""
    return np.array([float(f"{v:.6E}") for v in np.atleast_1d(np.asarray(x, dtype=float))])


def scientific(x: float) -> str:
    """Series 0015's number: ``+6.808018E+03``."""
    return f"{x:+.6E}"


@dataclass
class Relays:
    """A Preisach model as a finite set of relays: thresholds ``beta <= alpha``, weights, a bias and slope."""

    alpha: np.ndarray
    beta: np.ndarray
    weight: np.ndarray
    bias: float = 0.0
    slope: float = 0.0

    @classmethod
    def random(cls, n: int, lo: float, hi: float, seed: int = 0, bias: float = 0.0, slope: float = 0.0) -> "Relays":
        rng = np.random.default_rng(seed)
        a, b = rng.uniform(lo, hi, n), rng.uniform(lo, hi, n)
        # weights in quarters: the moments print exactly with 7 significant digits
        return cls(np.maximum(a, b), np.minimum(a, b), rng.integers(2, 6, n) / 4.0, bias, slope)

    def forc(self, r: float, x: np.ndarray) -> np.ndarray:
        """Closed form on the curve reversed at ``r`` (after positive saturation), at inputs ``x``."""
        x = np.asarray(x, dtype=float)
        down = (self.beta[None, :] > r) & (self.alpha[None, :] > x[:, None])
        return self.bias + self.slope * x + (np.where(down, -1.0, 1.0) * self.weight).sum(axis=1)

    def simulate(self, inputs: np.ndarray) -> np.ndarray:
        """Step the relays through ``inputs`` from negative saturation (every relay down)."""
        state = -np.ones(self.alpha.size)
        out = np.empty(len(inputs))
        for n, v in enumerate(inputs):
            state[v >= self.alpha] = 1.0
            state[v <= self.beta] = -1.0
            out[n] = self.bias + self.slope * v + state @ self.weight
        return out


@dataclass
class ForcData:
    """What a FORC file holds: per curve, the calibration point and the curve's fields and moments."""

    cal_field: list[float]
    cal_moment: list[float]
    fields: list[np.ndarray]
    moments: list[np.ndarray]
    settings: dict = field(default_factory=dict)

    @property
    def n_data(self) -> int:
        return len(self.cal_field) + sum(f.size for f in self.fields)


SETTINGS = {
    "h_sat": 0.5, "h_cal": 0.12, "h_ncr": 0.005, "hb1": -0.02, "hb2": 0.02, "hc1": 0.0, "hc2": 0.08,
    "averaging": 0.1, "pause_cal": 1.0, "pause_rev": 0.5, "pause_sat": 2.0, "slew": 1.0, "elapsed": None,
}


@dataclass
class GridForcs:
    """The FORCs of a grid :class:`~identify.PreisachModel`, each run from positive saturation at ``h_sat``."""

    model: object
    h_sat: float = 0.5

    def forc(self, r: float, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        return self.model.predict(np.concatenate([[self.h_sat, r], x]))[2:]


def forc_data(relays, reversals, step: float, top, settings: dict | None = None,
              cal_drift=None) -> ForcData:
    """Curves reversed at ``reversals`` up to ``top`` (a number, or one per curve) every ``step``.

    ``relays`` is anything with ``forc(r, x)`` (:class:`Relays`, :class:`GridForcs`).
    ``cal_drift(k)`` adds drift to calibration point ``k`` (default none).
    Values are rounded as the file prints them (:func:`printed`), so what
    is written is exactly what the data are.
    """
    s = {**SETTINGS, **(settings or {})}
    tops = np.broadcast_to(np.asarray(top, dtype=float), (len(reversals),))
    fields, moments, cal_f, cal_m = [], [], [], []
    for k, (r, t) in enumerate(zip(reversals, tops)):
        h = printed(r + step * np.arange(int(np.floor((t - r) / step + 1e-9)) + 1))
        fields.append(h)
        moments.append(printed(relays.forc(h[0], h)))
        cal = float(printed(s["h_cal"] - 0.0001)[0])
        cal_f.append(cal)
        cal_m.append(float(printed(relays.forc(cal, [cal])[0] + (cal_drift(k) if cal_drift else 0.0))[0]))
    return ForcData(cal_f, cal_m, fields, moments, s)


def _data_lines(data: ForcData, fmt) -> list[str]:
    lines = []
    for cf, cm, f, m in zip(data.cal_field, data.cal_moment, data.fields, data.moments):
        lines += [f"{fmt(cf)},{fmt(cm)}", ""]
        lines += [f"{fmt(a)},{fmt(b)}" for a, b in zip(f, m)]
        lines.append("")
    return lines


def _kv16(key: str, value: str) -> str:
    return f"{key:<31}{value if value.startswith(('+', '-', ' ')) else ' ' + value}"


def lines_0016(data: ForcData, *, units: str = "Hybrid SI", unit_line=("(T)", "(Am\u00b2)")) -> list[str]:
    """The lines of a Series 0016 file (without line endings)."""
    s, e = data.settings, engineering
    n = len(data.fields)
    elapsed = e(s["elapsed"]) if s["elapsed"] is not None else "N/A"
    sections = {
        "INSTRUMENT": [("Configuration", "VSM"), ("Temperature control", "None"), ("Hardware version", "0004"),
                       ("Software version", "06/08/2012"), ("Units of measure", units), ("Temperature in", "Kelvin")],
        "SAMPLE": [("Mass", "N/A"), ("Volume", "N/A"), ("Demagnetizing factor", "N/A")],
        "SETTINGS": [("Field range", e(0.3)), ("Field (command)", "N/A"), ("Moment range", e(1e-5)),
                     ("Averaging time", e(s["averaging"])), ("Sweep mode", "Continuous"),
                     ("Pause after sweep increment", e(0.3))],
        "MEASUREMENT": [("Description", '"test sample"'), ("Measured on", "11/08/2012  18:23"),
                        ("Elapsed time", elapsed)],
        "SCRIPT": [("Averaging time", e(s["averaging"])), ("Hb1", e(s["hb1"])), ("Hb2", e(s["hb2"])),
                   ("Hc1", e(s["hc1"])), ("Hc2", e(s["hc2"])), ("HCal", e(s["h_cal"])), ("HNcr", e(s["h_ncr"])),
                   ("HSat", e(s["h_sat"])), ("NForc", f" {n}"), ("PauseCal", e(s["pause_cal"])),
                   ("PauseRvrsl", e(s["pause_rev"])), ("PauseSat", e(s["pause_sat"])), ("SlewRate", e(s["slew"])),
                   ("Smoothing", " 3"), ("Includes hysteresis loop?", "No"), ("Includes Msi(H)?", "No"),
                   ("Number of segments", f" {2 * n}"), ("Number of data", f" {data.n_data}")],
    }
    lines = ["MicroMag 2900/3900 Data File (Series 0016.002)", "Direct moment vs. field; First-order reversal curves"]
    for name, entries in sections.items():
        lines += ["", name] + [_kv16(k, v) for k, v in entries]
    lines += ["", " " * 27, "    Field         Moment   ", f"     {unit_line[0]}          {unit_line[1]}    "]
    lines += _data_lines(data, engineering)
    lines.append("MicroMag 2900/3900 Data File ends")
    return lines


def lines_0015(data: ForcData, *, units: str = "cgs") -> list[str]:
    """The lines of a Series 0015 file (without line endings)."""
    s, f = data.settings, scientific
    elapsed = f(s["elapsed"]) if s["elapsed"] is not None else "N/A"

    def kv(key: str, value: str) -> str:
        return f"{key:<15}= {value}"

    lines = [
        "MicroMag 2900/3900 Data File (Series 0015)", "First-order reversal curves",
        "Configuration   :  VSM", "Hardware version:  0004", "Software version:  09/27/2005 D",
        f"Units of measure:  {units}", "Temperature in  :  Kelvin", "01/22/2015  17:35", '"test sample"', "",
        kv("Averaging time", f(s["averaging"])), kv("Hb1", f(s["hb1"])), kv("Hb2", f(s["hb2"])),
        kv("Hc1", f(s["hc1"])), kv("Hc2", f(s["hc2"])), kv("HCal", f(s["h_cal"])), kv("HNcr", f(s["h_ncr"])),
        kv("HSat", f(s["h_sat"])), kv("NCrv", str(len(data.fields))), kv("PauseCal", f(s["pause_cal"])),
        kv("PauseNtl", f(s["pause_rev"])), kv("PauseSat", f(s["pause_sat"])), kv("SlewRate", f(s["slew"])),
        kv("Smoothing", "3"), "",
        kv("Field range", f(0.3)), kv("Moment range", f(2e-3)), kv("Temperature", "N/A"),
        kv("Orientation", f(-90.0)), kv("Elapsed time", elapsed), kv("Slope corr.", "N/A"),
        kv("Saturation", "N/A"), kv("NData", str(data.n_data)), "",
    ]
    return lines + _data_lines(data, scientific)


def write_lines(path: Path, lines: list[str], newline: str = "\r\n") -> Path:
    """Write ``lines`` as Latin-1 with ``newline`` endings."""
    Path(path).write_bytes((newline.join(lines) + newline).encode("latin-1"))
    return Path(path)
