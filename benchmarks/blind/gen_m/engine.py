"""``simulate``: one session on one device, composing the mechanisms in their physical order.

temperature (thermal.py) -> film (film.py) -> deflection (mechanics.py) -> sensor (sensor.py) -> noise.

The state that survives between runs is physical: the slow heat paths cool
during the ~10 min the heater is off, the beam keeps creeping, the mount keeps
its position in its play, the film keeps its cycle count.  The film itself is
back in negative saturation at every run's start (minutes at 0 V).  A run
depends only on itself and the runs before it; its timing and its noise come
from streams keyed by its index (prefix stability).
"""

from __future__ import annotations

import numpy as np

from .film import Film
from .forms import LIBRARY, OUTSIDE
from .logger import run_noise, run_timing
from .mechanics import Backlash, Creep, FirstPoint, JoulePower, Reversible
from .scales import scales
from .sensor import BaselineDrift, GainDrift, SensorNonlinearity
from .thermal import AmbientDrift, ThermalNetwork

#: Sample points of the temperature along a dwell when it has slow dynamics (fractions of the dwell).
_DWELL_SAMPLES = np.concatenate([[0.0], np.geomspace(0.003, 1.0, 10)])


def _sort_effects(effects) -> dict[str, list[tuple[dict, float, int]]]:
    """``{family: [(form, strength, occurrence), ...]}`` for the strengths > 0."""
    out: dict[str, list] = {}
    count: dict[str, int] = {}
    for family, form, strength in effects:
        if family not in LIBRARY and family not in OUTSIDE:
            raise ValueError(f"unknown mechanism {family!r}")
        strength = float(strength)
        if not strength >= 0.0:
            raise ValueError(f"strength must be >= 0, got {strength!r} for {family}")
        occ = count.get(family, 0)
        count[family] = occ + 1
        if strength > 0.0:
            out.setdefault(family, []).append((form, strength, occ))
    return out


def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session.

    device:    base.BaseDevice
    schedules: list of dicts, one per run in order, each {"v_V": (n,) array, "dwell_s": (n,) array, "readings": K}
    effects:   list of (family, form, strength) with strength >= 0 (0: the mechanism is absent)
    seed:      int; every random choice of the realisation (a drift's path, the timing, the noise) comes from it
    noise_um:  rms noise (um) of one recorded point, or None for noise-free outputs
    returns:   one dict per run: {"t_s": (n,) s, "v_V": (n,) V, "y_um": (n,) um, "dwell_s": (n,) s}
               (this lab's logger writes dwell_s: the time from the set-point change to the reading)
    """
    sc = scales(device)
    eff = _sort_effects(effects)

    def pairs(name):
        return [(f, s) for f, s, _ in eff.get(name, [])]

    def build(name, cls, *extra):
        return [cls(device, sc, f, s, *extra) for f, s, _ in eff.get(name, [])]

    thermal = ThermalNetwork(device, pairs("thermal_lag")) if "thermal_lag" in eff else None
    ambients = [AmbientDrift(device, f, s, seed, o) for f, s, o in eff.get("ambient_drift", [])]
    film = Film(device, sc, pairs("interaction"), pairs("accommodation"), pairs("nucleation_kinetics"))
    joules = build("joule_power", JoulePower)
    revs = build("reversible", Reversible)
    creeps = build("creep", Creep)
    backlashes = build("backlash", Backlash)
    firsts = build("first_point", FirstPoint)
    nonlins = build("sensor_nonlinearity", SensorNonlinearity)
    gains = [GainDrift(device, sc, f, s, seed, o) for f, s, o in eff.get("gain_drift", [])]
    baselines = [BaselineDrift(device, sc, f, s, seed, o) for f, s, o in eff.get("baseline_drift", [])]
    k = float(device.kelvin_per_V2)

    results: list[dict] = []
    t_run0 = 0.0  # session time of the current run's clock zero (s)
    t_off = 0.0  # session time the heater was switched off after the previous run (s)
    creep_t = 0.0  # session time of the last change of the deflection (s)
    started = False
    for r, sched in enumerate(schedules):
        v_all = np.asarray(sched["v_V"], dtype=float)
        dwell = np.asarray(sched["dwell_s"], dtype=float)
        timing = run_timing(seed, r, dwell, int(sched.get("readings", 1)))
        n = v_all.size

        # -- the heater-off interval before this run (the first run starts from a long rest)
        if started:
            phase_off = film.drive(np.array([device.v_min_V]))
            u_off = device.output(phase_off, 0.0)
            for c in creeps:
                c.decay(t_off - creep_t)
                c.change(u_off, phase_off)
            creep_t = t_off
            y = u_off
            for b in backlashes:
                y = b(y)
            t_run0 = t_off + timing.gap_before_s
            if thermal is not None:
                thermal.advance(0.0, timing.gap_before_s)
        started = True
        if thermal is not None and n:
            thermal.advance(0.0, float(timing.t_set[0]))
        t_end = float(timing.t_next[-1]) if n else 0.0
        for d in (*ambients, *gains, *baselines):
            d.start_run(r, t_end)
        film.start_run()
        for fp in firsts:
            fp.reset()

        y_out = np.empty(n)
        v_prev, last_dir, level_start = device.v_min_V, 0, 0.0
        for i in range(n):
            v = float(v_all[i])
            t_set, t_read = float(timing.t_set[i]), float(timing.t_read[i])
            dt_read = t_read - t_set
            step = v - v_prev
            reversal = 0
            if step != 0.0:
                d = 1 if step > 0 else -1
                if last_dir != 0 and d != last_dir:
                    reversal = d
                last_dir = d
                level_start = t_set
            elif i == 0:
                level_start = t_set

            # -- temperature: the film's input along the dwell (equivalent V) and the beam's (V)
            if thermal is not None:
                s = dt_read * _DWELL_SAMPLES
                rise = thermal.rise(v, s)
                film_rise = rise + sum(a.delta_K(t_set + s) for a in ambients) if ambients else rise
                x = np.sqrt(np.maximum(film_rise, 0.0) / k)
                v_th = float(np.sqrt(max(rise[-1], 0.0) / k))
                hold = (t_set - level_start) + s
            elif ambients:
                film_rise = k * v * v + sum(a.delta_K(t_read) for a in ambients)
                x = np.array([np.sqrt(max(film_rise, 0.0) / k)])
                v_th = v
                hold = np.array([t_read - level_start])
            else:
                x, v_th, hold = np.array([v]), v, np.array([t_read - level_start])

            # -- film
            phase = film.drive(x, hold, last_dir)

            # -- deflection of the beam
            u = device.output(phase, v_th)
            for j in joules:
                u += j(v_th)
            for rv in revs:
                u += rv(float(x[-1]), v)
            for a in ambients:
                if a.um_per_K != 0.0:
                    u += a.bimorph_um(t_read)
            y = u
            if creeps:
                for c in creeps:
                    c.decay(t_run0 + t_set - creep_t)
                    c.change(u, phase)
                    y += c.offset(dt_read)
                creep_t = t_run0 + t_set
            for b in backlashes:
                y = b(y)
            for fp in firsts:
                y += fp.step(reversal, abs(step))

            # -- sensor
            for nl in nonlins:
                y = nl(y)
            for g in gains:
                y = g(y, t_read)
            for bl in baselines:
                y = bl(y, t_read)
            y_out[i] = y

            if thermal is not None:
                thermal.advance(v, float(timing.t_next[i]) - t_set)
            v_prev = v

        t_off = t_run0 + t_end
        y_out = y_out + run_noise(seed, r, n, noise_um)
        results.append({
            "t_s": timing.logged_t_s, "v_V": v_all.copy(), "y_um": y_out, "dwell_s": timing.logged_dwell_s,
        })
    return results
