"""rt_b: a blind thermal-dynamics simulator of the VO2 microactuator (see README.md).

Model, in one paragraph.  Temperatures are rises above ambient normalised by
the full-scale rise ``theta = T / (kelvin_per_V2 * v_max**2)``; the drive is
``u = (v / v_max)**2``, the film's steady rise.  The heater feeds a low-order
linear thermal network; its film and beam outputs are written in modal form
(the film's and the beam's step responses ``1 - sum_i a_i exp(-t/tau_i)``,
the same time constants, different weights; a negative fast weight is the
diffusion delay from the heater to the film at the tip).  Two temperature
dependences make the network nonlinear: the heat loss to ambient grows with
temperature (``G(T) = G0 (1 + beta T)``) and the silicon's specific heat grows
with temperature (``C(T) = C0 (1 + gamma T)``).  For a loss path ``C dT/dt =
P - G(T) T`` with ``P = G(u) u`` this is exactly ``dT/dt = (u - T) G0/C *
(1 + beta (u + T)) / (1 + gamma T)``: a *time warp* ``s`` multiplying every
rate.  We apply the warp, evaluated at the film's temperature, to the whole
network: in warped time ``sigma`` (``d sigma/dt = s``) the network is linear
and solved in closed form; ``t(sigma)`` is a scalar quadrature.  Steady states
are untouched by the warp (the film reaches ``u`` exactly).
"""

from __future__ import annotations

import functools
import json
import math

import numpy as np

from benchmarks.blind import base
from identify.memory import MemoryCurve

#: Warp reference: ``tau_s`` is the small-signal time constant at half the full-scale rise.
THETA_REF = 0.5


# ---------------------------------------------------------------------------------------------
# forms
# ---------------------------------------------------------------------------------------------


def instant_form() -> dict:
    """Infinitely fast thermal dynamics, no extras: the film is at steady state at once."""
    return {"kind": "rt_b", "instant": True, "tau_s": 0.0, "tau_modes_s": [], "film_weights": [],
            "beam_weights": [], "loss_growth": 0.0, "capacity_growth": 0.0, "extra": None}


def _monotone(a: np.ndarray, tau: np.ndarray) -> bool:
    """Is the step response ``1 - sum a exp(-t/tau)`` non-decreasing (impulse response >= 0)?"""
    t = np.concatenate([[0.0], np.geomspace(tau.min() * 1e-3, tau.max() * 60.0, 400)])
    d = (a[:, None] / tau[:, None] * np.exp(-t[None, :] / tau[:, None])).sum(axis=0)
    return bool(np.all(d >= -1e-12 * np.abs(a / tau).sum()))


def draw_form(tau_s: float, rng: np.random.Generator, extras: bool = True) -> dict:
    """A random thermal-dynamics form (JSON-safe) whose characteristic time constant is ``tau_s`` (s).

    ``tau_s``: the time constant of the slowest mode carrying at least 20 % of the film's steady
    rise, for small steps about half the full-scale rise (README.md).
    """
    tau_s = float(tau_s)
    if not tau_s > 0.0:
        raise ValueError("tau_s must be > 0")
    taus: list[float] = [tau_s]
    # one to three dominant modes; the characteristic one holds 25..90 % (if not alone)
    n_dom = int(rng.choice([1, 2, 3], p=[0.35, 0.4, 0.25]))
    if n_dom == 1:
        w = [1.0]
    else:
        wc = float(rng.uniform(0.25, 0.9))
        rest = rng.dirichlet(np.full(n_dom - 1, 2.0)) * (1.0 - wc)
        w = [wc] + [float(r) for r in rest]
        ratios = np.sort(np.exp(rng.uniform(np.log(0.04), np.log(0.6), n_dom - 1)))[::-1]
        taus += [tau_s * float(r) for r in ratios]
    # a small slow mode from the package (holder, board): 1.5..5 tau_s, 1..12 % of the rise
    if rng.uniform() < 0.6:
        wp = float(rng.uniform(0.01, 0.12))
        w = [x * (1.0 - wp) for x in w] + [wp]
        taus.append(tau_s * float(np.exp(rng.uniform(np.log(1.5), np.log(5.0)))))
    film = np.array(w)
    beam_extra: list[float] = []
    # a very fast mode (0.2..3 % of tau_s): the beam's own heating (a quick part of the rise), or
    # the heat's diffusion from the heater to the film at the tip (a small delay: negative weight)
    kind = rng.choice(["none", "quick", "delay"], p=[0.4, 0.3, 0.3])
    if kind != "none":
        tf = tau_s * float(np.exp(rng.uniform(np.log(0.002), np.log(0.03))))
        tarr = np.array(taus)
        if kind == "quick":
            wq = float(rng.uniform(0.02, 0.15))
            film = np.concatenate([film * (1.0 - wq), [wq]])
            beam_extra = [float(rng.uniform(1.0, 2.5)) * wq]
        else:
            # the impulse response stays >= 0 iff sum_pos a_i / tau_i >= d / tau_f (one negative mode)
            d_max = min(0.05, float(np.sum(film / tarr)) * tf)
            d = float(rng.uniform(0.3, 0.9)) * d_max
            film = np.concatenate([film * (1.0 + d), [-d]])
            beam_extra = [0.0]
        taus.append(tf)
    tau_arr = np.array(taus)
    # the beam (what the thermal expansion follows) is nearer the heater (rho > 0: leads the film)
    # or integrates over a longer, cooler stretch (rho < 0: lags it)
    rho = float(rng.uniform(-0.25, 0.5))
    n_main = len(w)
    beam = np.concatenate([np.clip(film[:n_main], 0.0, None) * (tau_arr[:n_main] / tau_s) ** (-rho),
                           beam_extra])
    beam = beam / beam.sum()
    while not _monotone(film, tau_arr):  # never expected; a safeguard
        neg = film < 0
        film[neg] *= 0.5
        film[~neg] *= (1.0 - film[neg].sum()) / film[~neg].sum()
    extra = None
    if extras:
        if rng.uniform() < 0.5:
            extra = {"kind": "drift", "amplitude_rel": float(rng.uniform(3e-4, 1e-3)),
                     "period_s": float(np.exp(rng.uniform(np.log(600.0), np.log(6000.0)))),
                     "phase": float(rng.uniform(0.0, 2.0 * np.pi))}
        else:
            extra = {"kind": "creep", "amplitude_rel": float(rng.uniform(3e-4, 1e-3)),
                     "tau_s": float(np.exp(rng.uniform(np.log(5.0), np.log(60.0))))}
    return {
        "kind": "rt_b", "instant": False, "tau_s": tau_s,
        "tau_modes_s": [float(x) for x in tau_arr],
        "film_weights": [float(x) for x in film],
        "beam_weights": [float(x) for x in beam],
        "loss_growth": float(rng.uniform(0.0, 0.3)),
        "capacity_growth": float(rng.uniform(0.0, 0.1)),
        "extra": extra,
    }


def characteristic_tau_s(form: dict) -> float:
    """The slowest mode whose film weight is >= 20 % (the definition of ``tau_s``)."""
    tau = np.array(form["tau_modes_s"])
    a = np.array(form["film_weights"])
    return float(tau[a >= 0.2].max())


# ---------------------------------------------------------------------------------------------
# the time warp
# ---------------------------------------------------------------------------------------------


def _warp(form: dict, theta_u, theta_f):
    """``s = d sigma / dt`` (1 at small signals about ``THETA_REF``)."""
    b, g = form["loss_growth"], form["capacity_growth"]
    norm = (1.0 + g * THETA_REF) / (1.0 + 2.0 * b * THETA_REF)
    tf = np.clip(theta_f, 0.0, 1.0)
    return norm * (1.0 + b * (theta_u + tf)) / (1.0 + g * tf)


def _warp_max(form: dict) -> float:
    b, g = form["loss_growth"], form["capacity_growth"]
    return (1.0 + g * THETA_REF) / (1.0 + 2.0 * b * THETA_REF) * (1.0 + 2.0 * b)


# ---------------------------------------------------------------------------------------------
# settling time
# ---------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=256)
def _settling_cached(form_json: str, tolerance: float) -> float:
    form = json.loads(form_json)
    if form["instant"]:
        return 0.0
    tau = np.array(form["tau_modes_s"])
    a = np.array(form["film_weights"])
    xs = np.concatenate([np.linspace(0.0, 1.0, 41), [0.02, 0.05, 0.98]])
    xa, xb = np.meshgrid(xs, xs, indexing="ij")
    keep = np.abs(xa - xb) > 1e-12
    xa, xb = xa[keep], xb[keep]
    ta, tb = xa**2, xb**2
    step = np.abs(xb - xa)
    up = xb > xa
    lo = np.maximum(xb - tolerance * step, 0.0)
    hi = xb + tolerance * step
    # residual fraction r = (theta - theta_b) / (theta_a - theta_b) at which the film is within tolerance
    r_star = np.where(up, (tb - lo**2) / (tb - ta), (hi**2 - tb) / (ta - tb))
    r_star = np.clip(r_star, 1e-300, 1.0)

    def resid(sig):
        return (a[None, :] * np.exp(-sig[:, None] / tau[None, :])).sum(axis=1)

    # log-bisection for the first sigma with resid <= r_star (resid decreases monotonically)
    lo_s = np.full(xa.shape, math.log(tau.min() * 1e-6))
    hi_s = np.full(xa.shape, math.log(tau.max() * 200.0))
    for _ in range(70):
        mid = 0.5 * (lo_s + hi_s)
        ok = resid(np.exp(mid)) <= r_star
        hi_s = np.where(ok, mid, hi_s)
        lo_s = np.where(ok, lo_s, mid)
    sig_star = np.exp(hi_s)
    sig_star = np.where(r_star >= 1.0, 0.0, sig_star)
    # t = integral_0^sigma* d sigma / s(theta_u, theta_f(sigma))
    frac = np.concatenate([[0.0], np.geomspace(1e-6, 1.0, 300)])
    sig = sig_star[:, None] * frac[None, :]
    r = (a[None, None, :] * np.exp(-sig[:, :, None] / tau[None, None, :])).sum(axis=2)
    theta = tb[:, None] + (ta - tb)[:, None] * r
    inv = 1.0 / _warp(form, tb[:, None], theta)
    t = np.sum(0.5 * (inv[:, 1:] + inv[:, :-1]) * np.diff(sig, axis=1), axis=1)
    return float(t.max()) * 1.0005  # a hair of margin for the quadrature


def settling_time_s(form: dict, tolerance: float) -> float:
    """Longest time (s) after any set-point step within the device's range until the film's
    temperature (as an equivalent voltage) stays within ``tolerance`` (a fraction of the step) of
    its new steady state.

    Steps from steady state between any two voltages of ``[0, v_max]`` (a grid of 44 levels,
    both ends included).  The film's step response is monotone, so the first entry into the band
    is the last.  Independent of the device: the form is written in normalised rises.
    """
    return _settling_cached(json.dumps(form, sort_keys=True), float(tolerance))


# ---------------------------------------------------------------------------------------------
# the film's phase transition, fast (exact, the same as base.Hysteresis)
# ---------------------------------------------------------------------------------------------


class _Film:
    """The Preisach memory (identify.memory.MemoryCurve) and an O(corners) phase evaluation.

    The phase is ``2 P - swing`` with ``P`` the density integral over the +1 region, integrated
    exactly for the cell-wise uniform density.  Equal to ``base.Hysteresis`` (tested).
    """

    def __init__(self, device: base.BaseDevice) -> None:
        grid = device.grid
        L = device.levels
        self.grid, self.L = grid, L
        mu = np.zeros((L, L))
        mu[grid.cell_alpha, grid.cell_beta] = device.density_um / grid.cell_area
        self.mu = mu
        self.swing = float(np.sum(device.density_um))
        diag = np.diag(mu).copy()
        S = np.array([mu[i, :i].sum() for i in range(L)])
        self.diag, self.S = diag, S
        self.Dcum = np.concatenate([[0.0], np.cumsum(S + 0.5 * diag)])
        self.R = np.concatenate([np.zeros((L, 1)), np.cumsum(mu, axis=1)[:, :-1]], axis=1)
        self.W = np.concatenate([np.zeros((1, L)), np.cumsum(self.R, axis=0)], axis=0)
        self.V = np.concatenate([np.zeros((1, L)), np.cumsum(mu, axis=0)], axis=0)
        self.curve = MemoryCurve(L)
        # plain-float tables, column-major for the E part (indexed [jb][row])
        self._Dcum, self._S, self._diag = self.Dcum.tolist(), S.tolist(), diag.tolist()
        self._Wt, self._Vt = self.W.T.tolist(), self.V.T.tolist()
        self._Rt, self._mut = self.R.T.tolist(), mu.T.tolist()

    def coordinates(self, v: np.ndarray) -> np.ndarray:
        return self.grid.coordinates(np.asarray(v, dtype=float))

    def move(self, c: float) -> None:
        self.curve.apply(c)

    def _M(self, al: float, b: float) -> float:
        """Density integral over ``{alpha' < al, beta < min(b, alpha')}`` (plain floats: fast)."""
        L1 = self.L - 1
        y = al if al < b else b
        i = int(y)
        if i > L1:
            i = L1
        t = y - i
        out = self._Dcum[i] + t * self._S[i] + 0.5 * self._diag[i] * t * t
        if al > b:
            jb = int(b)
            if jb > L1:
                jb = L1
            fb = b - jb
            W, V, R, mu = self._Wt[jb], self._Vt[jb], self._Rt[jb], self._mut[jb]
            iz = int(al)
            if iz > L1:
                iz = L1
            tz = al - iz
            fa = W[iz] + fb * V[iz] + tz * (R[iz] + fb * mu[iz])
            tz = b - jb
            fbb = W[jb] + fb * V[jb] + tz * (R[jb] + fb * mu[jb])
            out += fa - fbb
        return out

    def phase(self) -> float:
        a, b = self.curve._a, self.curve._b  # read-only use of the corners
        P = 0.0
        n = len(a)
        M = self._M
        for k in range(n):
            P += M(a[k], b[k]) - (M(a[k + 1], b[k]) if k + 1 < n else 0.0)
        return 2.0 * P - self.swing


# ---------------------------------------------------------------------------------------------
# one run
# ---------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=16)
def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


_N_SIGMA = 96
_UNIT = np.linspace(0.0, 1.0, _N_SIGMA)


def simulate(device, schedule: dict, form: dict, seed: int, noise_um: float | None) -> dict:
    """One run (see README.md).  ``t_s``: the end of each point's last reading (of its dwell if
    not measured); ``y_um``: the mean of its readings, each the sensor's average over its own
    window (Gauss-Legendre quadrature of the deflection over the window); NaN where not measured.
    A measured point with 0 readings is read once."""
    v = np.asarray(schedule["v_V"], dtype=float)
    n = v.size
    dwell = np.asarray(schedule["dwell_s"], dtype=float) * np.ones(n)
    readings = np.asarray(schedule["readings"], dtype=int) * np.ones(n, dtype=int)
    measured = np.asarray(schedule["measured"], dtype=bool) * np.ones(n, dtype=bool)
    reading_s = float(schedule["reading_s"])
    if np.any(dwell < 0) or reading_s < 0:
        raise ValueError("dwell_s and reading_s must be >= 0")
    vmax = float(device.v_max_V)
    vclip = np.clip(v, 0.0, vmax)
    u_all = (vclip / vmax) ** 2
    k_eff = np.where(measured, np.maximum(readings, 1), 0)
    window = k_eff * reading_s

    film = _Film(device)
    instant = bool(form["instant"])
    if not instant:
        tau = np.array(form["tau_modes_s"])
        aF = np.array(form["film_weights"])
        aB = np.array(form["beam_weights"])
        mF = np.zeros(tau.size)
        mB = np.zeros(tau.size)
        smax = _warp_max(form)
        sig_lo = tau.min() / 30.0

    extra = form.get("extra")
    swing = device.phase_swing_um
    if extra and extra["kind"] == "creep":
        rng_u = 2.0 * swing + abs(device.thermal_um_per_V) * vmax + 1e-12
        creep_c = extra["amplitude_rel"] * swing / rng_u
        creep_tau = extra["tau_s"]
        u0 = device.output(-swing, 0.0)
        creep_f = u0

    t_out = np.zeros(n)
    y = np.full(n, np.nan)
    t0 = 0.0
    for k in range(n):
        T = dwell[k] + window[k]
        u = u_all[k]
        if measured[k]:
            K = int(k_eff[k])
            if reading_s > 0:
                nq = min(2 * K, 6) if K > 1 else 2
                gx, gw = _gauss(nq)
                tq = dwell[k] + gx * window[k]
            else:
                gw, tq = np.array([1.0]), np.array([dwell[k]])
        else:
            gw, tq = np.zeros(0), np.zeros(0)
        if instant:
            c = film.coordinates(np.array([vclip[k]]))[0]
            film.move(c)
            ph = film.phase()
            xb_q = np.full(tq.size, vclip[k])
            ph_q = np.full(tq.size, ph)
            u_end = device.output(ph, vclip[k])
        else:
            dF = mF - aF * u
            dB = mB - aB * u
            if T > 0:
                span = math.log(max(T * smax * 1.0001, sig_lo * 2.0) / sig_lo)
                sg = np.concatenate([[0.0], sig_lo * np.exp(_UNIT * span)])
                e = np.exp(-sg[:, None] / tau[None, :])
                thF = u + e @ dF
                inv = 1.0 / _warp(form, u, thF)
                tg = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(sg))])
                sig_end = float(np.interp(T, tg, sg))
                sig_q = np.interp(tq, tg, sg)
                # extremes of the film's temperature before sig_end
                der = -(e * (dF / tau)[None, :]).sum(axis=1)
                sgn = np.sign(der)
                idx = np.nonzero((sgn[:-1] * sgn[1:] < 0) & (sg[:-1] < sig_end))[0]
                sig_x = sg[idx] - der[idx] * (sg[idx + 1] - sg[idx]) / (der[idx + 1] - der[idx])
                sig_x = np.minimum(sig_x, sig_end)
            else:
                sig_end, sig_q, sig_x = 0.0, tq * 0.0, np.zeros(0)
            # events in time order: extremes (0), quadrature nodes (1), the end (2)
            ev_s = np.concatenate([sig_x, sig_q, [sig_end]])
            ev_k = np.concatenate([np.zeros(sig_x.size), np.ones(sig_q.size), [2.0]])
            order = np.lexsort((ev_k, ev_s))
            ev_s, ev_k = ev_s[order], ev_k[order]
            ee = np.exp(-ev_s[:, None] / tau[None, :])
            thF_ev = np.clip(u + ee @ dF, 0.0, 1.0)
            thB_ev = np.clip(u + ee @ dB, 0.0, 1.0)
            cs = film.coordinates(vmax * np.sqrt(thF_ev))
            ph_q, xb_q = [], []
            for j in range(ev_s.size):
                film.move(float(cs[j]))
                if ev_k[j] >= 1.0:
                    ph = film.phase()
                    if ev_k[j] == 1.0:
                        ph_q.append(ph)
                        xb_q.append(vmax * math.sqrt(thB_ev[j]))
            ph_q, xb_q = np.array(ph_q), np.array(xb_q)
            u_end = device.output(ph, vmax * math.sqrt(thB_ev[-1]))
            eN = np.exp(-sig_end / tau)
            mF = aF * u + dF * eN
            mB = aB * u + dB * eN
        if measured[k]:
            vals = device.bias_um + device.thermal_um_per_V * xb_q + ph_q
            if extra and extra["kind"] == "drift":
                tt = t0 + tq
                vals = vals + extra["amplitude_rel"] * swing * np.sin(
                    2.0 * np.pi * tt / extra["period_s"] + extra["phase"])
            elif extra and extra["kind"] == "creep":
                # the deflection's slow part follows it with a lag (u taken as stepping to u_end)
                cf = u_end + (creep_f - u_end) * np.exp(-tq / creep_tau)
                vals = vals + creep_c * (cf - u0)
            y[k] = float(np.dot(gw, vals))
        if extra and extra["kind"] == "creep":
            creep_f = u_end + (creep_f - u_end) * math.exp(-T / creep_tau)
        t0 += T
        t_out[k] = t0

    if noise_um is not None and noise_um > 0:
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7274_5F62]))
        z = rng.standard_normal(int(k_eff.sum()))
        ends = np.cumsum(k_eff)
        starts = ends - k_eff
        for k in np.nonzero(measured)[0]:
            y[k] += noise_um * float(z[starts[k]:ends[k]].mean())
    return {"t_s": t_out, "v_V": v.copy(), "y_um": y}
