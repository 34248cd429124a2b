"""Thermal forms of rt_c: a random lumped heat-capacity network, reduced to its modes.

The network (relative units; the time scale is fixed afterwards by ``tau_s``):

* ``H`` (optional) the heater trace: a tiny heat capacity tightly coupled to
  the film region -- a very fast mode;
* ``F`` the film region of the cantilever (the heater's power enters here
  when there is no separate heater node);
* ``B`` the rest of the beam;
* ``A`` the anchor / chip;
* ``P`` (optional) the package: a large capacity well tied to ambient, so a
  slow mode with a small share of the film's rise.

Conductances join H-F, F-B, B-A, A-ambient, A-P, P-ambient, plus small losses
to the air from F and B.  ``C dT/dt = -G T + e_in p`` is reduced to its modes
(all real, all decaying); the film's normalised step response is
``1 - sum_i w_i exp(-t / tau_i)`` and the beam's (the mean temperature the
thermal expansion follows) ``1 - sum_i wb_i exp(-t / tau_i)``.  Both are
monotone (a passive network driven by a non-negative power never overshoots).

Heating and cooling differ through a time stretch ``g`` applied to every mode
during a set-point (see :func:`stretch`): a temperature-dependent heat loss,
the heater's positive temperature coefficient (power falls as it warms, so
the heater-on approach is quicker than the free cool-down), and the latent
heat of the film's transition (a larger apparent heat capacity while the
film's temperature crosses its transition band).
"""

from __future__ import annotations

import math

import numpy as np

#: The rig's full-scale heater voltage (V): levels are fractions of its steady rise.
V_FULL_SCALE = 6.0
#: The characteristic mode: the slowest carrying at least this share of the film's rise.
DOMINANT_SHARE = 0.2


def _loguniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _modes(C: dict, G: list, input_node: str, film: str, beam_mix: float):
    """Modal time constants and normalised weights of the film and the beam (``F``/``B`` mix)."""
    names = list(C)
    idx = {n: k for k, n in enumerate(names)}
    n = len(names)
    K = np.zeros((n, n))
    for a, b, g in G:
        if b == "0":
            K[idx[a], idx[a]] += g
        else:
            ia, ib = idx[a], idx[b]
            K[ia, ia] += g
            K[ib, ib] += g
            K[ia, ib] -= g
            K[ib, ia] -= g
    c = np.array([C[k] for k in names])
    s = 1.0 / np.sqrt(c)
    S = s[:, None] * K * s[None, :]
    lam, V = np.linalg.eigh(S)
    b = V.T @ (s * (np.arange(n) == idx[input_node]))   # modal input
    out = s[:, None] * V                                  # node temperatures from modal states
    gain = out * (b / lam)[None, :]                        # steady contribution of each mode per node
    film = gain[idx[film]]
    beam = (1.0 - beam_mix) * gain[idx["F"]] + beam_mix * gain[idx["B"]]
    return 1.0 / lam, film / film.sum(), beam / beam.sum()


def draw_network(tau_s: float, rng: np.random.Generator) -> dict:
    """Draw networks until the film's modes fit the family; scale time so the dominant mode is ``tau_s``."""
    for _ in range(10_000):
        heater = bool(rng.random() < 0.4)
        package = bool(rng.random() < 0.5)
        C = {"F": _loguniform(rng, 0.2, 1.0)}
        if heater:
            C["H"] = C["F"] * _loguniform(rng, 2e-3, 3e-2)
        C["B"] = _loguniform(rng, 0.3, 3.0)
        C["A"] = _loguniform(rng, 0.5, 6.0)
        G = [("F", "B", _loguniform(rng, 0.5, 8.0)),
             ("B", "A", _loguniform(rng, 0.3, 4.0)),
             ("A", "0", _loguniform(rng, 0.3, 4.0)),
             ("F", "0", _loguniform(rng, 0.005, 0.2)),
             ("B", "0", _loguniform(rng, 0.005, 0.3))]
        if heater:
            G.append(("H", "F", _loguniform(rng, 3.0, 30.0)))
        if package:
            C["P"] = _loguniform(rng, 5.0, 150.0)
            G.append(("A", "P", _loguniform(rng, 0.3, 3.0)))
            G.append(("P", "0", _loguniform(rng, 2.0, 20.0)))
        beam_mix = float(rng.uniform(0.3, 1.0))
        taus, w, wb = _modes(C, G, "H" if heater else "F", "F", beam_mix)
        order = np.argsort(taus)[::-1]                      # slowest first
        taus, w, wb = taus[order], w[order], wb[order]
        big = np.nonzero(w >= DOMINANT_SHARE)[0]
        if big.size == 0:
            continue
        d = int(big[0])
        slower = slice(0, d)
        if np.sum(np.abs(w[slower])) > 0.15 or (d > 0 and taus[0] > 5.0 * taus[d]):
            continue
        if taus[-1] < 1e-4 * taus[d]:
            continue
        scale = tau_s / taus[d]
        # drop modes too small to matter anywhere (keeps the stepping cheap)
        keep = (np.abs(w) > 1e-6) | (np.abs(wb) > 1e-6)
        taus, w, wb = taus[keep] * scale, w[keep], wb[keep]
        return {
            "nodes": {k: float(v) for k, v in C.items()},
            "links": [[a, b, float(g)] for a, b, g in G],
            "beam_mix": beam_mix,
            "time_scale_s": float(scale),
            "tau_modes_s": [float(t) for t in taus],
            "film_weights": [float(x) for x in w / w.sum()],
            "beam_weights": [float(x) for x in wb / wb.sum()],
        }
    raise RuntimeError("no network found")  # pragma: no cover


def stretch(form: dict, level_start: float, level_target: float, overlap: float) -> float:
    """Time stretch of every mode during a set-point.

    ``level_*``: the film's rise as a fraction of the full-scale rise, at the
    set-point's start and its target; ``overlap``: the fraction of that span
    inside the film's transition band for this direction (0..1).  ``g = 1``
    for a small step at mid-range (level 0.5) outside the band.
    """
    kl, kt, lat = form["kappa_loss"], form["kappa_tcr"], form["latent"]
    g0 = 1.0 + 0.5 * kl + 0.5 * kt
    mean = 0.5 * (level_start + level_target)
    return g0 / (1.0 + kl * mean + kt * level_target) * (1.0 + lat * overlap)


def residual(taus: np.ndarray, w: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Film's normalised residual ``sum w_i exp(-s / tau_i)`` at times ``s`` (unstretched)."""
    return np.exp(-np.asarray(s)[..., None] / taus) @ w


def settling_time_s(form: dict, tolerance: float) -> float:
    taus = np.asarray(form["tau_modes_s"], dtype=float)
    if taus.size == 0:
        return 0.0
    w = np.asarray(form["film_weights"], dtype=float)
    tol = float(tolerance)
    v = np.linspace(0.0, V_FULL_SCALE, 61)
    va, vb = np.meshgrid(v, v, indexing="ij")
    va, vb = va.ravel(), vb.ravel()
    step = va != vb
    va, vb = va[step], vb[step]
    dv = np.abs(vb - va)
    D = np.abs(vb ** 2 - va ** 2)
    heat = vb > va
    # the largest residual fraction f of the rise step whose equivalent voltage is within tol * dv
    f_heat = (vb ** 2 - np.maximum(vb - tol * dv, 0.0) ** 2) / D
    f_cool = ((vb + tol * dv) ** 2 - vb ** 2) / D
    F = np.where(heat, f_heat, f_cool)
    Ls, Lt = (va / V_FULL_SCALE) ** 2, (vb / V_FULL_SCALE) ** 2
    kl, kt = form["kappa_loss"], form["kappa_tcr"]
    g = (1.0 + 0.5 * kl + 0.5 * kt) / (1.0 + kl * 0.5 * (Ls + Lt) + kt * Lt) * (1.0 + form["latent"])
    # invert the monotone residual on the distinct tolerances (bisection in log time)
    Fu, inv = np.unique(F, return_inverse=True)
    lo = np.full(Fu.shape, math.log(taus.min() * 1e-6))
    hi = np.full(Fu.shape, math.log(taus.max() * (50.0 + 3.0 * abs(math.log(max(Fu.min(), 1e-300))))))
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        above = residual(taus, w, np.exp(mid)) > Fu
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    s = np.exp(hi)[inv]
    return float(np.max(g * s))
