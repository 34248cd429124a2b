"""One session: the runs in order, every mechanism composed in its physical order.

temperature (ambient_drift, thermal_lag) -> film (interaction, accommodation; the base Preisach
hysterons) -> deflection (joule_power, reversible, creep, first_point; backlash of the lever's mount)
-> sensor (interference_fringes, sensor_nonlinearity, gain_drift, baseline_drift) -> noise.
"""

from __future__ import annotations

import numpy as np

from .. import base
from ._util import reference, stream
from .forms import LIBRARY, OUTSIDE
from .mechanisms import (
    AmbientDrift, Accommodation, Backlash, BaselineDrift, Creep, Film, FirstPoint, GainDrift,
    InterferenceFringes, Interaction, JoulePower, Reversible, SensorNonlinearity, ThermalLag,
)

#: times (s) after a set-point change at which the film's temperature is followed within a dwell
_SUBTIMES = np.array([0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0])


class Timing:
    """The logger's clock in one run, from the run's own stream.

    The set-point is applied at ``t0``; the program waits the scheduled dwell plus a command and
    scheduling latency, then reads the PSD ``K`` times at the DAQ's sample period (the burst) and
    averages; the reading's time stamp is the burst's middle.  After a small overhead the next
    set-point is applied.  ``gap_s`` is the heater-off time before this run (used from the 2nd run).
    """

    def __init__(self, seed: int, run: int, dwell: np.ndarray, K: int):
        rng = stream(seed, run, "timing")
        start = float(rng.uniform(0.2, 2.0))
        lat_base = float(rng.uniform(0.02, 0.2))
        sample_dt = float(rng.uniform(0.5e-3, 5e-3))
        over_base = float(rng.uniform(0.005, 0.05))
        self.gap_s = 600.0 * float(rng.uniform(0.92, 1.12))
        n = dwell.size
        lat = lat_base + rng.exponential(0.01, n)
        over = over_base + rng.exponential(0.005, n)
        burst = min(max(int(K), 1) * sample_dt, 0.6)
        self.to_read = dwell + lat + 0.5 * burst
        self.interval = dwell + lat + burst + over
        self.t0 = start + np.concatenate([[0.0], np.cumsum(self.interval[:-1])])[:n]
        self.t_read = self.t0 + self.to_read
        self.t_end = float(self.t0[-1] + self.interval[-1]) if n else 0.0


class Session:
    def __init__(self, device, effects: dict, seed: int):
        self.device, self.seed = device, seed
        ref = reference(device)
        self.ref = ref

        def get(name, build):
            return build(*effects[name]) if name in effects else None

        self.thermal = get("thermal_lag", lambda f, s: ThermalLag(f, s, device, ref))
        self.ambient = get("ambient_drift", lambda f, s: AmbientDrift(f, s))
        inter = get("interaction", lambda f, s: Interaction(f, s, ref))
        self.acc = get("accommodation", lambda f, s: Accommodation(f, s, device, ref))
        self.film = Film(device, inter, self.acc)
        self.joule = get("joule_power", lambda f, s: JoulePower(f, s, device, ref))
        self.rev = get("reversible", lambda f, s: Reversible(f, s, device, ref))
        self.creep = get("creep", lambda f, s: Creep(f, s, device, ref))
        self.fp = get("first_point", lambda f, s: FirstPoint(f, s, device, ref))
        self.backlash = get("backlash", lambda f, s: Backlash(f, s, ref))
        self.fringes = get("interference_fringes", lambda f, s: InterferenceFringes(f, s, ref))
        self.nonlin = get("sensor_nonlinearity", lambda f, s: SensorNonlinearity(f, s, ref))
        self.gain = get("gain_drift", lambda f, s: GainDrift(f, s))
        self.baseline = get("baseline_drift", lambda f, s: BaselineDrift(f, s, ref))
        self.run_index = 0

    # ------------------------------------------------------------------ between runs
    def _gap(self, dt: float) -> None:
        """The heater off for ``dt`` seconds between two runs."""
        dev = self.device
        if self.thermal is not None:
            self.thermal.advance(0.0, dt)
        if self.creep is not None:
            T_K = 273.15 + dev.ambient_C
            self.creep.advance(self.creep.driver(-self.ref.phase_half_um, 0.0), T_K, dt)

    # ------------------------------------------------------------------ one run
    def run(self, run: int, v: np.ndarray, tim: Timing) -> np.ndarray:
        dev, seed = self.device, self.seed
        if run > 0:
            self._gap(tim.gap_s)
        for mech in (self.ambient, self.fringes, self.gain, self.baseline):
            if mech is not None:
                mech.begin_run(seed, run, tim.t_end)
        if self.fp is not None:
            self.fp.begin_run(seed, run, v.size)
        film = self.film
        film.begin_run()
        if self.backlash is not None:
            self.backlash.start(dev.bias_um + film.phase())
        k, c = dev.kelvin_per_V2, dev.thermal_um_per_V
        dynamic_T = self.thermal is not None or self.ambient is not None
        y = np.empty(v.size)
        v_prev = dev.v_min_V
        for n in range(v.size):
            vn = float(v[n])
            q = k * vn * vn
            tr = float(tim.to_read[n])
            # ---- temperature
            if self.thermal is not None:
                sub = np.append(_SUBTIMES[_SUBTIMES < tr], tr)
                rs = self.thermal.rise(q, sub)
            else:
                sub = np.array([tr])
                rs = np.array([q])
            r_read = float(rs[-1])
            dT = self.ambient(tim.t0[n] + sub) if self.ambient is not None else np.zeros_like(sub)
            dT_read = float(dT[-1])
            # ---- film
            if dynamic_T:
                film.follow(dev.equivalent_voltage(rs + dT))
                v_th = float(dev.equivalent_voltage(r_read)) if self.thermal is not None else vn
            else:
                film.move(vn)
                v_th = vn
            phase = film.phase()
            # ---- deflection
            if self.joule is not None:
                v_th = self.joule.thermal_input(v_th, r_read)
            th = c * v_th
            u = dev.bias_um + th + phase
            if self.rev is not None:
                u += self.rev(vn, r_read, dT_read, v_th)
            T_K = 273.15 + dev.ambient_C + dT_read + r_read
            if self.creep is not None:
                D = self.creep.driver(phase, th)
                u += self.creep.read(D, T_K, tr)
            if self.fp is not None:
                u += self.fp(n, vn - v_prev)
            if self.backlash is not None:
                u = self.backlash.apply(u)
            # ---- sensor
            t = float(tim.t_read[n])
            p = u
            if self.fringes is not None:
                p += self.fringes(u, t)
            if self.nonlin is not None:
                p = self.nonlin(p)
            if self.gain is not None:
                p *= self.gain(t)
            if self.baseline is not None:
                p += self.baseline(t)
            y[n] = p
            # ---- to the next set-point
            dt = float(tim.interval[n])
            if self.thermal is not None:
                self.thermal.advance(q, dt)
            if self.creep is not None:
                self.creep.advance(D, T_K, dt)
            v_prev = vn
        # the heater goes off after the run: the film cools back (its cycles count for accommodation)
        if self.acc is not None:
            film.move(dev.v_min_V)
        return y


def _active(effects) -> dict:
    known = LIBRARY + OUTSIDE
    out = {}
    for family, form, strength in effects:
        if family not in known:
            raise ValueError(f"unknown mechanism {family!r}")
        s = float(strength)
        if not np.isfinite(s) or s < 0:
            raise ValueError(f"strength must be >= 0, got {strength!r}")
        if s > 0:
            if family in out:
                raise ValueError(f"mechanism {family!r} given twice")
            out[family] = (form, s)
    return out


def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session (see the package docstring)."""
    active = _active(effects)
    session = Session(device, active, int(seed)) if active else None
    runs = []
    for r, sched in enumerate(schedules):
        v = np.asarray(sched["v_V"], dtype=float).copy()
        dwell = np.asarray(sched["dwell_s"], dtype=float)
        if dwell.shape != v.shape:
            raise ValueError("v_V and dwell_s must have the same shape")
        tim = Timing(int(seed), r, dwell, int(sched.get("readings", 1)))
        if session is None:
            y = base.clean_outputs(device, v)
        else:
            y = session.run(r, v, tim)
        if noise_um is not None and float(noise_um) > 0:
            y = y + float(noise_um) * stream(int(seed), r, "noise").standard_normal(v.size)
        runs.append({"t_s": tim.t_read.copy(), "v_V": v, "y_um": np.asarray(y, dtype=float),
                     "dwell_s": tim.to_read.copy()})
    return runs
