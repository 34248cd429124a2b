"""``simulate``: one session of runs on one device, with the mechanisms in their physical order.

Timing (the logger, see README): set-point ``n`` is written to the heater driver at
``T[n]`` (run clock, ``T[0] = 0``); the PC sleeps ``dwell_s[n]`` and wakes a
little late (USB command + scheduler latency, a few ms); the PSD is then read
``K`` times at ``SAMPLE_S`` (burst well under a second) and averaged; the
recorded time ``t_s`` is the middle of the burst and the logger also writes
``dwell_s`` = ``t_s - T[n]`` (the real time from the set-point change to the
reading).  The next set-point follows after the burst and a short write
overhead.  Between runs the heater is off for ``GAP_S``.

Random streams: every run has its own streams for timing, noise and each
drift's path, seeded by (seed, run index, purpose), so a run never depends on
how many runs follow it, on the strengths, or on the other mechanisms.
"""

from __future__ import annotations

import zlib

import numpy as np

from .. import base
from . import mechanisms as M
from .forms import LIBRARY, OUTSIDE

GAP_S = 600.0
SAMPLE_S = 0.02
_TAG = 0x6E4C_2611
_SUBQ = np.array([0.0, 0.003, 0.01, 0.03, 0.08, 0.17, 0.3, 0.5, 0.75, 1.0])
_KNOWN = set(LIBRARY) | set(OUTSIDE)


def _stream(seed: int, run: int, purpose: str) -> np.random.Generator:
    code = zlib.crc32(purpose.encode())
    return np.random.default_rng(np.random.SeedSequence([_TAG, int(seed) % 2**63, int(run), code]))


def _timing(seed: int, run: int, dwell: np.ndarray, K: int):
    """Set-point times ``T`` (n+1,: T[n] is the run's end) and reading times ``t`` (n,), run clock (s)."""
    n = dwell.size
    rng = _stream(seed, run, "timing")
    late = 0.003 + rng.exponential(0.008, n)      # the PC wakes late from its sleep
    write = 0.002 + rng.exponential(0.004, n)     # logging overhead before the next set-point
    sample = min(SAMPLE_S, 0.5 / max(K, 1))
    burst = max(K, 1) * sample
    step = dwell + late + burst + write
    T = np.concatenate([[0.0], np.cumsum(step)])
    t = T[:-1] + dwell + late + 0.5 * burst
    return T, t


def _turning_points(x0: float, xs: np.ndarray) -> list[float]:
    """The extrema (and the end) of the path ``x0 -> xs``: enough for a rate-independent memory."""
    pts = [float(x0)]
    for x in xs:
        x = float(x)
        if x == pts[-1]:
            continue
        if len(pts) >= 2 and (pts[-1] - pts[-2]) * (x - pts[-1]) > 0:
            pts[-1] = x
        else:
            pts.append(x)
    return pts[1:]


class _Ctx:
    """The device's output swing on its major loop (um), used to size the effects."""

    def __init__(self, device):
        up = np.linspace(device.v_min_V, device.v_max_V, 61)
        y = base.clean_outputs(device, np.r_[up, up[::-1][1:]])
        self.lo, self.hi = float(y.min()), float(y.max())
        self.swing = max(self.hi - self.lo, 1e-9)
        self.mid = 0.5 * (self.hi + self.lo)


def _parse(effects) -> dict:
    active: dict = {}
    for fam, form, strength in effects or ():
        if fam not in _KNOWN:
            raise ValueError(f"unknown mechanism {fam!r}")
        s = float(strength)
        if not np.isfinite(s) or s < 0:
            raise ValueError(f"strength of {fam} must be >= 0, got {strength!r}")
        if fam in active:
            raise ValueError(f"mechanism {fam!r} given twice")
        if form is None:
            from .forms import draw_form
            form = draw_form(fam, np.random.default_rng(zlib.crc32(fam.encode())))
        if s > 0:
            active[fam] = (form, s)
    return active


def simulate(device, schedules, effects, seed, noise_um) -> list[dict]:
    """Simulate one session (see SPEC.md and README.md)."""
    act = _parse(effects)
    k = device.kelvin_per_V2
    ctx = _Ctx(device) if act else None

    def make(fam, build):
        return build(*act[fam]) if fam in act else None

    thermal = make("thermal_lag", lambda f, s: M.Thermal(f, s, k, device.v_max_V))
    ambient = make("ambient_drift", lambda f, s: M.Ambient(f, s, device))
    inter = make("interaction", lambda f, s: M.Interaction(f, s, M.phase_slope_max(device)))
    acc = make("accommodation", lambda f, s: M.Accommodation(f, s, np.asarray(device.density_um, float),
                                                             M.film_geometry(device)))
    joule = make("joule_power", lambda f, s: M.Joule(f, s, device, ctx.swing))
    rev = make("reversible", lambda f, s: M.Reversible(f, s, device, ctx.swing))
    creep = make("creep", lambda f, s: M.Creep(f, s, ctx.swing))
    creep_phase = creep is not None and act["creep"][0].get("driver") == "phase"
    back = make("backlash", lambda f, s: M.Backlash(f, s, ctx.swing))
    refl = make("phase_reflectance", lambda f, s: M.Reflectance(f, s, ctx.lo, ctx.hi))
    nonlin = make("sensor_nonlinearity", lambda f, s: M.SensorNL(f, s, ctx.lo, ctx.hi))
    gain = make("gain_drift", lambda f, s: M.Gain(f, s, ctx.mid, ctx.swing))
    baseline = make("baseline_drift", lambda f, s: M.Baseline(f, s, ctx.swing))
    first = make("first_point", lambda f, s: M.FirstPoint(f, s, ctx.swing))

    film = M.Film(device, inter, acc)
    timedep = thermal is not None or ambient is not None
    clock = 0.0  # session clock (s) at the start of the current run
    rest_phase = film.h.value()
    prev_drive = rest_phase if creep_phase else device.output(rest_phase, 0.0)
    if back is not None:
        back.rest(device.output(rest_phase, 0.0))

    out = []
    for r, sch in enumerate(schedules):
        v = np.asarray(sch["v_V"], dtype=float)
        dwell = np.asarray(sch["dwell_s"], dtype=float)
        K = int(sch.get("readings", 1))
        n = v.size
        T, t = _timing(seed, r, dwell, K)
        for mech in (ambient, gain, baseline):
            if mech is not None:
                mech.start_run(_stream(seed, r, type(mech).__name__), T[-1])
        if first is not None:
            first.start_run()
        film.start_run()
        last_x = device.v_min_V  # the raw input the hysterons last felt (before any mean field)
        y = np.empty(n)
        for i in range(n):
            vi = v[i]
            # ---- temperature -> film
            if timedep:
                tl = T[i] + _SUBQ * (t[i] - T[i])
                if thermal is not None:
                    thermal.set_power(vi * vi, clock + T[i])
                    rise = thermal.rise(clock + tl)
                else:
                    rise = np.full(tl.size, k * vi * vi)
                dT = ambient.dT(tl) if ambient is not None else np.zeros(tl.size)
                xs = np.sqrt(np.maximum(rise + dT, 0.0) / k)
                phase = None
                for x in _turning_points(last_x, xs):
                    phase = film.go(x)
                if phase is None:
                    phase = film.go(xs[-1])
                last_x = float(xs[-1])
                rise_r, dT_r = float(rise[-1]), float(dT[-1])
                v_th = float(np.sqrt(max(rise_r, 0.0) / k)) if thermal is not None else vi
            else:
                phase = film.go(vi)
                rise_r, dT_r, v_th = k * vi * vi, 0.0, vi
            # ---- deflection
            if joule is not None:
                v_th = joule(v_th)
            u = device.output(phase, v_th)
            if rev is not None:
                u += rev(rise_r, dT_r)
            if ambient is not None and ambient.um_per_K:
                u += ambient.um_per_K * dT_r
            if creep is not None:
                drive = phase if creep_phase else u
                creep.event(clock + T[i], drive - prev_drive)
                prev_drive = drive
                u += creep.value(clock + t[i])
            # ---- mount, optics, sensor
            if back is not None:
                u = back(u)
            if refl is not None:
                u = refl(u, film.phase_norm(phase))
            if nonlin is not None:
                u = nonlin(u)
            if gain is not None:
                u = gain(u, t[i])
            if baseline is not None:
                u = baseline(u, t[i])
            if first is not None:
                u += first(vi)
            y[i] = u
        # ---- heater off between runs: the film cools to saturation, slow states relax
        end = clock + T[-1]
        film.go(device.v_min_V)
        rest_phase = film.h.value() if acc is None else float(film.weights() @ film._areas)
        if thermal is not None:
            thermal.set_power(0.0, end)
        if creep is not None:
            drive = rest_phase if creep_phase else device.output(rest_phase, 0.0)
            creep.event(end, drive - prev_drive)
            prev_drive = drive
        if back is not None:
            back.rest(device.output(rest_phase, 0.0))
        clock = end + GAP_S
        if noise_um is not None and noise_um > 0:
            y = y + float(noise_um) * _stream(seed, r, "noise").standard_normal(n)
        out.append({"t_s": t.copy(), "v_V": v.copy(), "y_um": y, "dwell_s": t - T[:-1]})
    return out
