"""``simulate``: one session, stage by stage in the physical order.

temperature (``thermal``) -> film (``film``) -> deflection (``expansion``,
``mechanics``) -> read-out (``sensor``) -> logger (``logger``).  Every stage
carries its slow state from run to run (the heater off between runs); the
film's memory restarts in negative saturation at every run, as SPEC.md says.
"""

from __future__ import annotations

import numpy as np

from .expansion import Joule
from .film import Film, MeanField, Reversible, Training, path_turns
from .logger import noise, record, run_clock
from .mechanics import Backlash, Creep, FirstPoint
from .names import ALL
from .scales import device_ref
from .sensor import Nonlinearity, Sensor
from .thermal import Aging, SlowPaths, Thermal


def _active(effects) -> dict:
    out: dict = {}
    for family, form, strength in effects:
        if family not in ALL:
            raise KeyError(f"unknown mechanism {family!r}")
        s = float(strength)
        if not s >= 0.0 or not np.isfinite(s):
            raise ValueError(f"strength of {family} must be finite and >= 0, got {strength!r}")
        if s > 0.0:
            if family in out:
                raise ValueError(f"{family} given twice")
            out[family] = (form, s)
    return out


class Session:
    def __init__(self, device, effects) -> None:
        self.device = device
        fx = _active(effects)
        self.fx = fx
        ref = device_ref(device) if fx else None
        self.ref = ref
        get = fx.get
        self.thermal = Thermal(
            device, ref,
            SlowPaths(*fx["thermal_lag"], device, ref) if "thermal_lag" in fx else None,
            Aging(*fx["conductance_aging"], ref) if "conductance_aging" in fx else None,
            get("ambient_drift"),
        )
        self.film = Film(
            device,
            MeanField(*fx["interaction"], device, ref) if "interaction" in fx else None,
            Training(*fx["accommodation"], device) if "accommodation" in fx else None,
        )
        self.joule = Joule(*fx["joule_power"], device, ref) if "joule_power" in fx else None
        self.reversible = Reversible(*fx["reversible"], device, ref) if "reversible" in fx else None
        self.creep = Creep(*fx["creep"], ref) if "creep" in fx else None
        self.first = FirstPoint(*fx["first_point"], ref, device.v_max_V - device.v_min_V) if "first_point" in fx else None
        self.backlash = Backlash(*fx["backlash"], ref) if "backlash" in fx else None
        sensor_parts = ("sensor_nonlinearity", "baseline_drift", "gain_drift")
        self.sensor = None
        if any(k in fx for k in sensor_parts):
            self.sensor = Sensor(ref, Nonlinearity(*fx["sensor_nonlinearity"], ref) if "sensor_nonlinearity" in fx else None,
                                 get("baseline_drift"), get("gain_drift"))

    def _deflection(self, v: float, x: float, vt: float, phase: float) -> float:
        term = self.joule(vt) if self.joule is not None else vt
        u = self.device.output(phase, term)
        if self.reversible is not None:
            u += self.reversible(v, x)
        return u

    def _creep_source(self, u: float, phase: float) -> float:
        return u if self.creep.form["source"] == "total" else phase

    def run(self, seed: int, index: int, schedule: dict) -> tuple:
        dev = self.device
        v_all = np.asarray(schedule["v_V"], dtype=float)
        clock = run_clock(seed, index, np.asarray(schedule["dwell_s"], dtype=float), int(schedule.get("readings", 1)))
        t_end = float(clock.next_s[-1]) if v_all.size else 0.0
        th, film = self.thermal, self.film
        th.start_run(seed, index, clock.gap_before_s, t_end + 60.0)
        film.start_run()
        if self.sensor is not None:
            self.sensor.start_run(seed, index, clock.read_s)
        if self.first is not None:
            self.first.start_run()

        # at rest: the heater off (for long before the first run; for the gap before the others)
        x_prev, vt_rest = th.rest_input(0.0) if th.active else (dev.v_min_V, 0.0)
        if th.active and x_prev > dev.v_min_V:
            film.move(x_prev)
        if self.creep is not None:
            phase0 = film.value()
            u0 = self._deflection(0.0, x_prev, vt_rest, phase0)
            # the heater went off at the previous run's end: that change has relaxed over the gap
            self.creep.launch(self._creep_source(u0, phase0))
            if np.isfinite(clock.gap_before_s):
                self.creep.advance(clock.gap_before_s, 0.0)

        y = np.empty(v_all.size)
        dwell_read = clock.dwell_logged_s
        for n, v in enumerate(v_all):
            v = float(v)
            film.set_weights_for_next()
            if th.active:
                xs, vt, rise = th.setpoint(v, float(clock.change_s[n]), th.offsets(float(dwell_read[n])))
                for z in path_turns(x_prev, xs):
                    phase = film.move(z)
                x_read = x_prev = float(xs[-1])
            else:
                phase = film.move(v)
                x_read = x_prev = vt = v
                rise = dev.kelvin_per_V2 * v * v
            u = self._deflection(v, x_read, vt, phase)
            if self.creep is not None:
                self.creep.launch(self._creep_source(u, phase))
                u = u - self.creep.pending(float(dwell_read[n]), rise)
                self.creep.advance(float(clock.next_s[n] - clock.change_s[n]), rise)
            if self.first is not None:
                u = u + self.first(v)
            if self.backlash is not None:
                u = self.backlash(u)
            if self.sensor is not None:
                u = self.sensor(n, u)
            y[n] = u
            th.leave(v, rise, float(clock.next_s[n] - clock.change_s[n]))
        return clock, v_all, y


def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session (SPEC.md): one dict per run, ``t_s``, ``v_V``, ``y_um``, ``dwell_s``."""
    session = Session(device, list(effects))
    out = []
    for index, schedule in enumerate(schedules):
        clock, v, y = session.run(int(seed), index, schedule)
        out.append(record(clock, v, y + noise(int(seed), index, v.size, noise_um)))
    return out
