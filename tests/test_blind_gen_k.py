"""Tests of the blind generator gen_k (benchmarks/blind/gen_k): the rules of benchmarks/blind/SPEC.md."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.blind import base
from benchmarks.blind import gen_k as G

FAMILIES = G.LIBRARY + G.OUTSIDE


def _schedules(seed: int = 0, short: bool = True) -> list[dict]:
    """A shortened session: a damped oscillation on the grid's walls, then a random-reversal check run."""
    walls = np.linspace(0.0, 6.0, 31)
    lo, hi, up, seq = 0, 30, True, []
    while hi > lo:
        seq.extend(range(lo + 1, hi + 1) if up else range(hi - 1, lo - 1, -1))
        lo, hi = (lo + 1, hi) if up else (lo, hi - 1)
        up = not up
    v1 = walls[np.array(seq[: 160 if short else 467])]
    rng = np.random.default_rng(seed)
    v2 = [0.0]
    for _ in range((90 if short else 360) - 1):
        if rng.uniform() < 0.1:
            v2.append(v2[-1])
        else:
            step = np.exp(rng.uniform(np.log(0.002), np.log(6.0))) * rng.choice([-1.0, 1.0])
            v2.append(float(np.clip(v2[-1] + step, 0.0, 6.0)))
    v2 = np.array(v2)
    return [{"v_V": v1, "dwell_s": np.full(v1.size, 20.0), "readings": 16},
            {"v_V": v2, "dwell_s": rng.uniform(8.0, 60.0, size=v2.size), "readings": 16}]


@pytest.fixture(scope="module")
def device():
    return base.draw_device(11)


@pytest.fixture(scope="module")
def schedules():
    return _schedules()


@pytest.fixture(scope="module")
def clean(device, schedules):
    return [base.clean_outputs(device, s["v_V"]) for s in schedules]


def _form(family: str, k: int = 0) -> dict:
    return G.draw_form(family, np.random.default_rng([7, k, FAMILIES.index(family)]))


def test_names():
    assert len(G.LIBRARY) == 10 and len(set(G.LIBRARY)) == 10
    assert G.OUTSIDE[:2] == ("backlash", "accommodation") and len(G.OUTSIDE) == 3
    assert not set(G.LIBRARY) & set(G.OUTSIDE)


def test_forms_are_json_safe_and_reproducible():
    for fam in FAMILIES:
        for k in range(3):
            f = _form(fam, k)
            assert json.loads(json.dumps(f)) == f
            assert f == _form(fam, k)
    with pytest.raises(ValueError):
        G.draw_form("no_such_thing", np.random.default_rng(0))


def test_strength_zero_is_the_clean_device(device, schedules, clean):
    for effects in ([], [(fam, _form(fam), 0.0) for fam in FAMILIES]):
        out = G.simulate(device, schedules, effects, 3, None)
        assert len(out) == len(schedules)
        for r, o in enumerate(out):
            assert np.array_equal(o["y_um"], clean[r])
            assert np.array_equal(o["v_V"], schedules[r]["v_V"])


def test_determinism(device, schedules):
    eff = [("thermal_lag", _form("thermal_lag"), 1.3), ("baseline_drift", _form("baseline_drift"), 0.7)]
    a = G.simulate(device, schedules, eff, 5, 0.05)
    b = G.simulate(device, schedules, eff, 5, 0.05)
    c = G.simulate(device, schedules, eff, 6, 0.05)
    for ra, rb, rc in zip(a, b, c):
        for key in ra:
            assert np.array_equal(ra[key], rb[key])
        assert not np.array_equal(ra["y_um"], rc["y_um"])


@pytest.mark.parametrize("family", FAMILIES)
def test_every_mechanism_changes_the_output_and_keeps_the_first_runs(family, device, schedules, clean):
    form = _form(family, 1)
    out = G.simulate(device, schedules, [(family, form, 1.0)], 2, None)
    y = np.concatenate([o["y_um"] for o in out])
    c = np.concatenate(clean)
    swing = np.ptp(c)
    d = np.abs(y - c)
    assert np.all(np.isfinite(y))
    assert d.max() > 1e-3 * swing          # visible
    assert d.max() < 0.15 * swing          # physical: a few percent, not a different device
    # more strength, more effect; tiny strength, tiny effect
    small = np.concatenate([o["y_um"] for o in G.simulate(device, schedules, [(family, form, 1e-4)], 2, None)])
    big = np.concatenate([o["y_um"] for o in G.simulate(device, schedules, [(family, form, 3.0)], 2, None)])
    assert np.abs(small - c).max() < 0.05 * d.max()
    assert np.sqrt(np.mean((big - c) ** 2)) > np.sqrt(np.mean((y - c) ** 2))
    # prefix stability: one more run appended (and one fewer) leaves the first runs exactly as they were
    extra = dict(schedules[1], v_V=schedules[1]["v_V"][::-1].copy())
    longer = G.simulate(device, schedules + [extra], [(family, form, 1.0)], 2, 0.03)
    noisy = G.simulate(device, schedules, [(family, form, 1.0)], 2, 0.03)
    first = G.simulate(device, schedules[:1], [(family, form, 1.0)], 2, 0.03)
    assert len(longer) == 3
    for r in range(2):
        for key in noisy[r]:
            assert np.array_equal(noisy[r][key], longer[r][key])
    for key in first[0]:
        assert np.array_equal(first[0][key], noisy[0][key])


def test_drift_realisations_do_not_depend_on_strength_or_company(device, schedules, clean):
    c = np.concatenate(clean)

    def y(effects, seed=4, noise=None):
        return np.concatenate([o["y_um"] for o in G.simulate(device, schedules, effects, seed, noise)])

    for fam in ("baseline_drift", "gain_drift"):
        f = _form(fam, 2)
        one, two = y([(fam, f, 1.0)]) - c, y([(fam, f, 2.0)]) - c
        assert np.allclose(two, 2 * one, rtol=0, atol=1e-9 * np.ptp(c))
    # the zero's drift is the same path with another mechanism present
    fb, fr = _form("baseline_drift", 3), _form("reversible", 3)
    alone = y([("baseline_drift", fb, 1.0)]) - c
    with_rev = y([("baseline_drift", fb, 1.0), ("reversible", fr, 1.0)]) - y([("reversible", fr, 1.0)])
    assert np.allclose(alone, with_rev, atol=1e-9 * np.ptp(c))
    # the room's temperature path too: the hysterons' response scales with it, it does not change shape
    fa = _form("ambient_drift", 1)
    a1, a2 = y([("ambient_drift", fa, 0.01)]) - c, y([("ambient_drift", fa, 0.02)]) - c
    assert np.corrcoef(a1, a2)[0, 1] > 0.95
    # the noise does not depend on the effects
    e1 = [("creep", _form("creep"), 1.0)]
    e2 = [("interaction", _form("interaction"), 0.5), ("gain_drift", _form("gain_drift"), 1.0)]
    n1 = y(e1, noise=0.05) - y(e1)
    n2 = y(e2, noise=0.05) - y(e2)
    assert np.allclose(n1, n2, atol=1e-12)
    assert 0.03 < np.std(n1) < 0.07


def test_logger_times(device, schedules):
    out = G.simulate(device, schedules, [("creep", _form("creep"), 1.0)], 9, None)
    for o, s in zip(out, schedules):
        assert np.all(np.diff(o["t_s"]) > 0)
        assert np.all(o["dwell_s"] >= s["dwell_s"]) and np.all(o["dwell_s"] < s["dwell_s"] + 1.0)
        assert o["t_s"][0] >= o["dwell_s"][0]
