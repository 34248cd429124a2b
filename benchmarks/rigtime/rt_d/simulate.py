"""One rig run on a device with a distributed cantilever's thermal dynamics."""

from __future__ import annotations

import math

import numpy as np

from .preisach import Memory, everett
from .thermal import Network, Segment

_NOISE_TAG = 0x7274_64  # "rtd"


def _noise(seed: int, counts: np.ndarray, noise_um: float | None) -> np.ndarray:
    """Mean of ``counts[k]`` independent N(0, noise_um^2) readings per point (form-independent)."""
    out = np.zeros(counts.size)
    if noise_um is None or noise_um == 0.0 or counts.size == 0:
        return out
    rng = np.random.default_rng(np.random.SeedSequence([_NOISE_TAG, int(seed) & 0xFFFFFFFFFFFF]))
    total = int(counts.sum())
    z = rng.standard_normal(total) * float(noise_um)
    pos = counts > 0
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    if total:
        sums = np.add.reduceat(z, starts[pos])
        out[pos] = sums / counts[pos]
    return out


def _schedule(schedule: dict):
    v = np.asarray(schedule["v_V"], dtype=float).ravel()
    n = v.size
    dwell = np.broadcast_to(np.asarray(schedule["dwell_s"], dtype=float), (n,)).astype(float)
    k = np.broadcast_to(np.asarray(schedule["readings"], dtype=int), (n,)).astype(int)
    meas = np.broadcast_to(np.asarray(schedule.get("measured", np.ones(n, bool)), dtype=bool), (n,))
    r = float(schedule.get("reading_s", 0.0))
    if np.any(dwell < 0) or np.any(k < 0) or r < 0:
        raise ValueError("dwell_s, readings and reading_s must be >= 0")
    # a measured point takes at least one reading
    k_eff = np.where(meas, np.maximum(k, 1), 0)
    return v, dwell, k_eff, meas, r


def _gauss(q: int):
    x, w = np.polynomial.legendre.leggauss(q)
    return 0.5 * (x + 1.0), 0.5 * w


_GAUSS = {q: _gauss(q) for q in (1, 2, 3)}
#: Fractions (log scale) of a set-point's duration at which the film's path is scanned for extremes.
_UNIT = np.linspace(0.0, 1.0, 48)


def simulate(device, schedule: dict, form: dict, seed: int, noise_um: float | None) -> dict:
    """One run (see SPEC.md).  Returns ``{"t_s", "v_V", "y_um"}``."""
    v, dwell, k_eff, meas, r = _schedule(schedule)
    n = v.size
    seg_len = dwell + k_eff * r
    t_start = np.concatenate([[0.0], np.cumsum(seg_len)[:-1]])
    t_read = t_start + seg_len
    noise = _noise(seed, k_eff, noise_um)
    y = np.full(n, np.nan)
    if form.get("kind") == "instant":
        h = device.hysteresis()
        for i in range(n):
            ph = h.move(float(v[i]))
            if meas[i]:
                y[i] = device.output(ph, float(v[i])) + noise[i]
        return {"t_s": t_read, "v_V": v.copy(), "y_um": y}
    return _run_beam(device, form, v, dwell, k_eff, meas, r, t_start, t_read, noise, y)


def _run_beam(device, form, v, dwell, k_eff, meas, r, t_start, t_read, noise, y):
    net = Network(form)
    ev = everett(device)
    M = net.M
    mems = [Memory(ev) for _ in range(M)]
    S = ev.S
    kpv2 = float(device.kelvin_per_V2)
    g = net.gain
    share = net.share
    theta = np.zeros(net.n)
    vh = 0.0
    duty = float(form.get("psd_duty", 1.0))
    extra = form.get("extra")
    creep_eps = 0.0
    creep_tau = 1.0
    if extra and extra["kind"] == "creep":
        dmax = 2.0 * S + abs(float(device.thermal_um_per_V)) * float(device.v_max_V)
        creep_eps = float(extra["amp_frac"]) * S / dmax
        creep_tau = float(extra["tau_s"])
    u_slow = None  # the creep's lagging deflection
    mode_cache: dict = {}
    for i in range(v.size):
        vi = float(v[i])
        T_len = float(dwell[i] + k_eff[i] * r)
        # ---- frozen capacities for this set-point
        out_now = net.H @ theta
        lat = np.zeros(M)
        if net.latent_K > 0.0:
            for j in range(M):
                dT = kpv2 * abs(vi * vi * g[j] - out_now[j])
                if dT > 1e-9:
                    dphi = abs(mems[j].peek(vi) - mems[j].pc) / (2.0 * S)
                    lat[j] = min(net.latent_cap, net.latent_K * dphi / dT)
        C = net.capacities(kpv2 * vi * vi * net.gamma, lat)
        key = C.tobytes()
        modes = mode_cache.get(key)
        if modes is None:
            modes = net.modes(C)
            if len(mode_cache) < 512:
                mode_cache[key] = modes
        seg = Segment(net, C, theta, vh, vi, modes=modes)
        # ---- the reading instants (quadrature of each PSD averaging window)
        if meas[i]:
            K = int(k_eff[i])
            q = 3 if K <= 32 else (2 if K <= 64 else 1)
            xq, wq = _GAUSS[q]
            w0 = float(dwell[i]) + r * np.arange(K)
            a = w0 + (1.0 - duty) * r
            nodes = (a[:, None] + duty * r * xq[None, :]).ravel()
            weights = np.tile(wq, K) / K
        else:
            nodes = np.zeros(0)
            weights = np.zeros(0)
        t_end = T_len
        # ---- the film patches' temperatures at the reading instants and at the end
        t_ne = np.concatenate([nodes, [t_end]])
        dev_ne = seg.dev(t_ne)  # (nodes + 1, M + 1)
        th_ne = vi * vi * g + dev_ne
        # ---- turning points of each patch on the way (the hysterons must see every extreme)
        ext = [None] * M
        if T_len > 0.0:
            fast = seg.fastest_rate()
            t_lo = min(1e-3 / fast, 1e-3 * T_len)
            ts = np.concatenate([[0.0], t_lo * (T_len / t_lo) ** _UNIT, nodes])
            ts.sort()
            dd = seg.ddev(ts)[:, :M]
            sg = np.sign(dd)
            flips = (sg[:-1] * sg[1:] < 0).any(axis=0)
            if flips.any():
                ext = _turning_points(seg, ts, dd, seg.dev(ts), vi * vi * g, flips)
        phases = np.zeros((nodes.size, M))
        phase_end = np.zeros(M)
        for j in range(M):
            if ext[j] is None:
                ph = mems[j].trace(np.sqrt(np.maximum(th_ne[:, j], 0.0) / g[j]))
            else:
                et = ext[j]
                path_t = np.concatenate([et, t_ne])
                order = np.argsort(path_t, kind="stable")
                th = np.concatenate([vi * vi * g[j] + seg.dev(et)[:, j], th_ne[:, j]])[order]
                ph_sorted = mems[j].trace(np.sqrt(np.maximum(th, 0.0) / g[j]))
                ph = np.empty_like(ph_sorted)
                ph[order] = ph_sorted
                ph = ph[et.size:]
            phases[:, j] = ph[:-1]
            phase_end[j] = ph[-1]
        # ---- the deflection at the reading instants and at the end
        v_th = np.sqrt(np.maximum(th_ne[:, M], 0.0) / g[M])
        u_ne = device.bias_um + device.thermal_um_per_V * v_th
        u_end = float(u_ne[-1] + phase_end @ share)
        if meas[i]:
            u_nodes = u_ne[:-1] + phases @ share
            if extra:
                tabs = t_start[i] + nodes
                if extra["kind"] == "drift":
                    d = np.zeros(nodes.size)
                    for P, phi, wgt in zip(extra["periods_s"], extra["phases"], extra["weights"]):
                        d += wgt * np.sin(2.0 * math.pi * tabs / P + phi)
                    u_nodes = u_nodes + float(extra["amp_frac"]) * S * d
                elif extra["kind"] == "creep" and u_slow is not None:
                    lagged = u_end + (u_slow - u_end) * np.exp(-nodes / creep_tau)
                    u_nodes = u_nodes + creep_eps * (lagged - u_nodes)
            y[i] = float(weights @ u_nodes) + noise[i]
        # ---- carry the state over
        if extra and extra["kind"] == "creep":
            u_slow = u_end if u_slow is None else u_end + (u_slow - u_end) * math.exp(-t_end / creep_tau)
        if T_len > 0.0:
            theta = seg.theta(t_end)
            vh = seg.vh(t_end)
    return {"t_s": t_read, "v_V": v.copy(), "y_um": y}


_REFINE = np.linspace(0.0, 1.0, 17)


def _turning_points(seg: Segment, ts: np.ndarray, dd: np.ndarray, dev: np.ndarray,
                    th_ss: np.ndarray, flips: np.ndarray) -> list:
    """Times of the local extrema of each patch's temperature, ``None`` where it is monotone.

    ``dd`` (T, M) its derivative and ``dev`` (T, M+1) its deviation on the scan ``ts``.  Every
    bracket where the derivative changes sign is narrowed (vectorised, 16 sub-intervals per round,
    4 rounds: the extreme value is then exact to ~1e-10 of the local variation).
    """
    M = dd.shape[1]
    js, ta, tb = [], [], []
    for j in np.flatnonzero(flips):
        s = np.sign(dd[:, j])
        idx = np.flatnonzero(s[:-1] * s[1:] < 0)
        scale = 1e-13 * (abs(th_ss[j]) + np.abs(dev[:, j]).max() + 1e-30)
        for k in idx:
            # skip numerical wiggles far below any hysteron's resolution
            if abs(dev[k + 1, j] - dev[k, j]) < scale and abs(dd[k, j]) * (ts[k + 1] - ts[k]) < scale:
                continue
            js.append(j)
            ta.append(ts[k])
            tb.append(ts[k + 1])
    out = [None] * M
    if not js:
        return out
    js = np.asarray(js)
    ta = np.asarray(ta, dtype=float)
    tb = np.asarray(tb, dtype=float)
    rows = np.arange(js.size)
    for _round in range(4):
        T = ta[:, None] + (tb - ta)[:, None] * _REFINE[None, :]
        D = seg.ddev(T.ravel()).reshape(js.size, _REFINE.size, -1)[rows, :, js]
        sg = np.sign(D)
        ch = (sg[:, :-1] * sg[:, 1:]) <= 0
        k = np.where(ch.any(axis=1), ch.argmax(axis=1), 0)
        ta, tb = T[rows, k], T[rows, np.where(ch.any(axis=1), k + 1, _REFINE.size - 1)]
    tm = 0.5 * (ta + tb)
    for j in np.unique(js):
        out[int(j)] = np.sort(tm[js == j])
    return out
