"""Drawing the withheld cases and calibrating their strengths.

A *case* is ``(split, seed, effects, level)``: no effect, one effect of a
family (:mod:`benchmarks.withheld.physics`), or two library effects at
once; ``level`` the gap each effect opens alone, in noise levels.  Every
random choice comes from a generator keyed by the seed and what it is for
(:func:`stream`), so a case is the same whichever subset is run, in
whichever order, on however many workers:

* ``stream(seed, "base")`` -- the device's physical parameters (:func:`draw_base`)
  and the check design's seed; shared by every case of that seed;
* ``stream(seed, family, "form", attempt)`` -- the family's form (the same
  in a pair as alone);
* ``stream(seed, family, "run", run)`` -- what differs between the runs (a
  drift's realisation);
* ``stream(seed, case label, level, "noise", run)`` -- the PSD noise of the
  recorded runs.

**Strength.** The gap an effect opens is measured on noise-free runs: the
rms over the check points of ``(model_eff - y_eff) - (model_0 - y_0)``,
``model`` identified by least squares (equation (22), thermal term on) on
the identification run with / without the effect, ``y`` the recorded check
outputs.  :func:`calibrate` finds the strength whose gap is ``level`` noise
levels (secant steps on log gap against log strength, kept inside a
bracket); a form that cannot reach it within its family's physical bound
is drawn again (``attempt`` 1, 2, ...; recorded in the manifest).

Run ``python -m benchmarks.withheld.generate --split headline --seeds 10``
to print the digest of the headline forms (see README.md).
"""

from __future__ import annotations

import argparse
import hashlib
import itertools
import json
import math
import sys
import time
import zlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivers.sim import SimParams
from identify import Grid
from identify.fit import fit_sequence

from . import physics
from .physics import FAMILIES, LIBRARY

#: The diagnosis's library as this benchmark scores it: the generator's library and ``gain_drift``, which has
#: since joined the diagnosis's library (the generator's physics of it is unchanged; it is no longer "outside").
SCORED_LIBRARY = (*LIBRARY, "gain_drift")
from .runs import (
    READINGS,
    RunPlan,
    check_plan,
    config,
    fit_plan,
    noise_free_outputs,
    record_run,
)

#: Mixed into every seed: changing it changes every case.
SALT = 20_150_015
#: Grid levels of the identification run (and of the device's true model).
LEVELS = 30
#: Seeds of each split.  Disjoint; the headline split is never used for tuning.
SPLITS: dict[str, range] = {"dev": range(1, 100_001), "headline": range(900_001, 1_000_001)}
#: How many pairs each seed contributes (walking through all 36 pairs in a fixed shuffled order).
PAIRS_PER_SEED = 4
#: Relative tolerance of the calibrated gap.
GAP_RTOL = 0.02
#: Forms drawn at most per (seed, family) before the family is declared unreachable for that seed.
MAX_ATTEMPTS = 6


class Unreachable(RuntimeError):
    """The form cannot open the target gap within its family's physical bound."""


# ====================================================================== seeds
def _key(part: Any) -> int:
    if isinstance(part, str):
        return zlib.crc32(part.encode())
    if isinstance(part, float):
        return zlib.crc32(repr(part).encode())
    return int(part)


def stream(*keys: Any) -> np.random.Generator:
    """A generator keyed by ``keys`` (ints, floats and strings), independent of every other key."""
    return np.random.default_rng(np.random.SeedSequence([SALT, *(_key(k) for k in keys)]))


def draw_base(seed: int) -> dict[str, Any]:
    """The device's physical parameters (``[sim]`` overrides) and its check design's seed."""
    rng = stream(seed, "base")
    heating = float(rng.uniform(62.0, 74.0))
    base = {
        "ambient_C": float(rng.uniform(20.0, 30.0)),
        "transition_heating_C": heating,
        "transition_cooling_C": heating - float(rng.uniform(5.0, 15.0)),
        "transition_width_C": float(rng.uniform(2.5, 7.0)),
        "transition_amplitude_um": float(rng.uniform(8.0, 20.0)),
        "bias_um": float(rng.uniform(-3.0, 5.0)),
        "thermal_um_per_V": float(rng.uniform(-3.0, -0.3)),
        "thermal_resistance_K_per_W": float(rng.uniform(12_000.0, 17_000.0)),
        "time_constant_s": float(rng.uniform(0.1, 0.5)),
    }
    check_seed = int(rng.integers(1, 2**31 - 1))
    return {"sim": base, "check_seed": check_seed}


def draw_form(seed: int, family: str, attempt: int = 0) -> dict[str, Any]:
    """Family ``family``'s form for ``seed`` (draw number ``attempt``)."""
    base = SimParams(levels=LEVELS, **draw_base(seed)["sim"])
    return physics.draw_form(family, stream(seed, family, "form", attempt), base)


def noise_seed(seed: int, label: str, level: float, run: int) -> int:
    return int(stream(seed, label, float(level), "noise", run).integers(1, 2**31 - 1))


# ====================================================================== cases
_PAIRS = list(itertools.combinations(LIBRARY, 2))
#: Every pair of library families, in a fixed shuffled order.
ALL_PAIRS: tuple[tuple[str, str], ...] = tuple(_PAIRS[int(i)] for i in np.random.default_rng(SALT).permutation(len(_PAIRS)))


@dataclass(frozen=True)
class Case:
    """One diagnosis: ``effects`` (none, one family, or two library families) at ``level`` noise levels."""

    split: str
    seed: int
    effects: tuple[str, ...]
    level: float

    @property
    def label(self) -> str:
        return "+".join(self.effects) if self.effects else "none"

    @property
    def kind(self) -> str:
        if not self.effects:
            return "none"
        if len(self.effects) > 1:
            return "pair"
        return "library" if self.effects[0] in SCORED_LIBRARY else "outside"

    @property
    def key(self) -> str:
        return f"{self.split}-{self.seed}-{self.label}-{self.level:g}sigma"


def split_seeds(split: str, n: int, skip: int = 0) -> list[int]:
    """Seeds ``skip .. skip + n - 1`` of ``split`` (in its order)."""
    seeds = SPLITS[split]
    if skip < 0 or n < 0 or skip + n > len(seeds):
        raise ValueError(f"the {split} split has {len(seeds)} seeds")
    return list(seeds[skip:skip + n])


def pairs_for(index: int, per_seed: int = PAIRS_PER_SEED) -> list[tuple[str, str]]:
    """The pairs of the ``index``-th seed of a split: the next ``per_seed`` of :data:`ALL_PAIRS`, cyclically."""
    return [ALL_PAIRS[(index * per_seed + j) % len(ALL_PAIRS)] for j in range(per_seed)]


def parse_selection(text: str | None) -> set[str]:
    """``--effects``: family names, ``A+B`` pairs, or the groups ``library``, ``outside``, ``none``, ``pairs``."""
    if not text:
        return {"library", "outside", "none", "pairs"}
    out = set()
    for tok in (t.strip() for t in text.split(",")):
        if not tok:
            continue
        names = tok.split("+")
        if tok in ("library", "outside", "none", "pairs"):
            out.add(tok)
        elif all(n in FAMILIES for n in names) and len(names) <= 2:
            out.add("+".join(sorted(names, key=LIBRARY.index)) if len(names) == 2 else tok)
        else:
            known = ", ".join([*FAMILIES, "library", "outside", "none", "pairs"])
            raise ValueError(f"--effects: unknown {tok!r} (known: {known}, or A+B)")
    return out


def make_cases(split: str, n_seeds: int, levels: Sequence[float] = (3.0,), selection: set[str] | None = None,
               pairs_per_seed: int = PAIRS_PER_SEED, skip: int = 0) -> list[Case]:
    """Every case of ``n_seeds`` seeds of ``split``, after its first ``skip``, that ``selection`` asks for
    (a seed's pairs follow from its place in the split, whatever is skipped)."""
    sel = selection if selection is not None else parse_selection(None)
    out: list[Case] = []
    for index, seed in enumerate(split_seeds(split, n_seeds, skip), start=skip):
        for level in levels:
            if "none" in sel:
                out.append(Case(split, seed, (), float(level)))
            for fam in FAMILIES:
                group = "library" if fam in SCORED_LIBRARY else "outside"
                if group in sel or fam in sel:
                    out.append(Case(split, seed, (fam,), float(level)))
            pairs = set(pairs_for(index, pairs_per_seed)) if "pairs" in sel else set()
            pairs |= {tuple(p.split("+")) for p in sel if "+" in p}  # type: ignore[misc]
            for pair in sorted(pairs, key=lambda p: (LIBRARY.index(p[0]), LIBRARY.index(p[1]))):
                out.append(Case(split, seed, tuple(pair), float(level)))
    return out


# ====================================================================== one seed's bench
Active = dict[str, tuple[dict[str, Any], float]]  # family -> (form, strength)


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


@dataclass
class Bench:
    """The device and runs of one seed: what every case of the seed shares."""

    seed: int
    base: dict[str, Any] = field(init=False)
    grid: Grid = field(init=False)
    fit: RunPlan = field(init=False)
    check: RunPlan = field(init=False)
    sigma_um: float = field(init=False)

    def __post_init__(self) -> None:
        self.base = draw_base(self.seed)
        cfg = self.config(0, noise=False)
        p = cfg.sim
        self.grid = Grid(LEVELS, p.v_min_V, p.v_max_V)
        self.fit = fit_plan(self.grid)
        self.check = check_plan(cfg, self.grid, self.base["check_seed"])
        noisy = self.config(0, noise=True).sim
        self.sigma_um = noisy.psd_noise_V * noisy.psd_um_per_V / math.sqrt(READINGS)
        self._r0: np.ndarray | None = None

    def config(self, noise_seed: int, noise: bool) -> Any:
        return config(self.base["sim"], LEVELS, noise_seed, noise)

    def effects(self, active: Active, run: int) -> list[physics.Withheld]:
        ctx = {"fit_travel_V": self.fit.travel_V()}
        return [physics.make_effect(name, s, form, run, stream(self.seed, name, "run", run), ctx)
                for name, (form, s) in active.items()]

    def device(self, active: Active, run: int, cfg: Any) -> physics.WithheldVO2:
        return physics.make_device(cfg.sim, self.effects(active, run))

    def noise_free(self, active: Active) -> tuple[np.ndarray, np.ndarray]:
        """Recorded outputs (um) of the identification and check runs without noise."""
        cfg = self.config(0, noise=False)
        y_fit = noise_free_outputs(cfg, self.device(active, 0, cfg), self.fit)
        y_chk = noise_free_outputs(cfg, self.device(active, 1, cfg), self.check)
        return y_fit, y_chk

    def residual(self, active: Active) -> np.ndarray:
        """``model - y`` on the check run (um), the model identified by ``ls`` on the noise-free identification run."""
        y_fit, y_chk = self.noise_free(active)
        model = fit_sequence(self.grid, self.fit.inputs, y_fit, "ls", thermal_term=True).model
        return model.predict(self.check.inputs) - y_chk

    def base_residual(self) -> np.ndarray:
        if self._r0 is None:
            self._r0 = self.residual({})
        return self._r0

    def gap_um(self, active: Active) -> float:
        """The gap ``active`` opens (um): rms of its check residual minus the clean device's."""
        return rms(self.residual(active) - self.base_residual())

    def record(self, active: Active, directory: Path, label: str, level: float) -> tuple[Path, Path]:
        """The noisy identification and check sessions (``fit.h5``, ``check.h5``) of a case."""
        directory.mkdir(parents=True, exist_ok=True)
        paths = []
        for run, plan in ((0, self.fit), (1, self.check)):
            cfg = self.config(noise_seed(self.seed, label, level, run), noise=True)
            note = f"withheld benchmark, seed {self.seed}, run {run}"
            paths.append(record_run(cfg, self.device(active, run, cfg), plan, directory / f"{plan.name}.h5", note))
        return paths[0], paths[1]


# ====================================================================== calibration
@dataclass
class Calibration:
    """A family's calibrated form on one seed: ``strength`` opens ``gap_um`` (target ``target_um``)."""

    seed: int
    family: str
    level: float
    form: dict[str, Any] | None = None
    attempt: int = 0
    strength: float | None = None
    gap_um: float | None = None
    target_um: float = 0.0
    evaluations: int = 0
    seconds: float = 0.0
    status: str = "ok"
    rejected: list[dict[str, Any]] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        return dict(self.__dict__)


def solve_strength(gap: Any, guess: float, target: float, max_strength: float | None,
                   rtol: float = GAP_RTOL, max_evals: int = 40) -> tuple[float, float, int]:
    """A strength whose ``gap(strength)`` is within ``rtol`` of ``target``: ``(strength, gap, evaluations)``.

    Secant steps on ``log gap`` against ``log strength`` (a small effect's gap
    goes as a power of its strength), kept inside the bracket once there is
    one (else a log-midpoint step).  Raises :class:`Unreachable` when the gap
    at ``max_strength`` is still short of the target.
    """
    lo: tuple[float, float] | None = None  # largest strength with gap below target
    hi: tuple[float, float] | None = None  # smallest strength with gap above target
    hist: list[tuple[float, float]] = []
    s = guess if max_strength is None else min(guess, max_strength)
    for n in range(1, max_evals + 1):
        g = gap(s)
        hist.append((s, g))
        if abs(g / target - 1.0) <= rtol:
            return s, g, n
        if g < target:
            if max_strength is not None and s >= max_strength:
                raise Unreachable(f"gap {g:.3g} um at the largest strength {s:g}, target {target:.3g} um")
            if lo is None or s > lo[0]:
                lo = (s, g)
        elif hi is None or s < hi[0]:
            hi = (s, g)
        # secant through the last two points in log-log, else assume gap ~ strength
        slope = 1.0
        if len(hist) >= 2:
            (s1, g1), (s2, g2) = hist[-2], hist[-1]
            if g1 > 0 and g2 > 0 and s1 != s2:
                slope = (math.log(g2) - math.log(g1)) / (math.log(s2) - math.log(s1))
            slope = min(max(slope, 0.25), 4.0) if math.isfinite(slope) else 1.0
        step = math.log(target / g) / slope if g > 0 else math.log(100.0)
        step = max(min(step, math.log(100.0)), -math.log(100.0))
        nxt = s * math.exp(step)
        if lo is not None and hi is not None:
            a, b = math.log(lo[0]), math.log(hi[0])
            x = math.log(nxt)
            if not (a + 0.05 * (b - a) < x < b - 0.05 * (b - a)):
                # secant lands outside or at the edge of the bracket: interpolate inside it instead
                ga, gb = math.log(max(lo[1], 1e-300)), math.log(hi[1])
                t = (math.log(target) - ga) / (gb - ga) if gb > ga else 0.5
                x = a + min(max(t, 0.1), 0.9) * (b - a)
            nxt = math.exp(x)
        if max_strength is not None:
            nxt = min(nxt, max_strength)
        s = nxt
    raise Unreachable(f"no strength within {rtol:.0%} of the target after {max_evals} evaluations")


def calibrate(bench: Bench, family: str, level: float) -> Calibration:
    """Draw ``family``'s form for ``bench.seed`` and find the strength that opens ``level`` noise levels."""
    t0 = time.perf_counter()
    fam = FAMILIES[family]
    target = level * bench.sigma_um
    cal = Calibration(bench.seed, family, float(level), target_um=target)
    for attempt in range(MAX_ATTEMPTS):
        form = draw_form(bench.seed, family, attempt)
        bound = fam.max_strength
        if family == "interaction":  # a stable coupling: the loop gain stays below one half
            bound = physics.interaction_bound(bench.config(0, noise=False).sim, form)
        try:
            s, g, n = solve_strength(lambda x, form=form: bench.gap_um({family: (form, x)}), fam.guess, target,
                                     bound)
        except Unreachable as exc:
            cal.rejected.append({"attempt": attempt, "form": form, "reason": str(exc)})
            continue
        cal.form, cal.attempt, cal.strength, cal.gap_um, cal.evaluations = form, attempt, s, g, n
        break
    else:
        cal.status = f"unreachable after {MAX_ATTEMPTS} forms"
    cal.seconds = time.perf_counter() - t0
    return cal


# ====================================================================== digests
def _rounded(x: Any) -> Any:
    if isinstance(x, float):
        return float(f"{x:.10g}")
    if isinstance(x, dict):
        return {k: _rounded(v) for k, v in sorted(x.items())}
    if isinstance(x, (list, tuple)):
        return [_rounded(v) for v in x]
    return x


def digest(obj: Any) -> str:
    """SHA-256 (first 16 hex digits) of ``obj``'s canonical JSON, floats to 10 significant digits."""
    text = json.dumps(_rounded(obj), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def draws(split: str, n_seeds: int, families: Iterable[str] = tuple(FAMILIES), skip: int = 0
          ) -> list[dict[str, Any]]:
    """The first draws (attempt 0) of every family and the base of each seed: no simulation."""
    fams = list(families)
    return [{"seed": s, "base": draw_base(s), "forms": {f: draw_form(s, f) for f in fams},
             "pairs": ["+".join(p) for p in pairs_for(i)]}
            for i, s in enumerate(split_seeds(split, n_seeds, skip), start=skip)]


def forms_digest(calibrations: Iterable[dict[str, Any]]) -> str:
    """Digest of the forms actually used (after redraws), per (seed, family, level), strengths excluded."""
    rows = sorted((c["seed"], c["family"], c["level"], c["attempt"], c["form"]) for c in calibrations
                  if c.get("form") is not None)
    return digest(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.withheld.generate", description=__doc__.split("\n")[0])
    ap.add_argument("--split", choices=sorted(SPLITS), default="headline")
    ap.add_argument("--seeds", type=int, default=10, help="N seeds of the split [10]")
    ap.add_argument("--skip", type=int, default=0, help="leave out the split's first K seeds [0]")
    ap.add_argument("--manifest", type=Path, help="write the draws (and with --calibrate the calibrations) here")
    ap.add_argument("--calibrate", action="store_true", help="also calibrate every family at --levels (slow)")
    ap.add_argument("--levels", default="3", help="gap levels in noise levels, comma-separated [3]")
    ap.add_argument("--workers", type=int, default=2, help="worker processes for --calibrate [2]")
    args = ap.parse_args(argv)
    d = draws(args.split, args.seeds, skip=args.skip)
    out: dict[str, Any] = {"split": args.split, "seeds": [r["seed"] for r in d], "draws": d,
                           "draws_digest": digest(d)}
    print(f"{args.split}: seeds {out['seeds'][0]}..{out['seeds'][-1]} ({len(d)}), draws digest {out['draws_digest']}")
    if args.calibrate:
        from rig.parallel import run_parallel

        from .jobs import calibration_job

        levels = [float(x) for x in args.levels.split(",")]
        jobs = [(s, fam, lv) for s in out["seeds"] for fam in FAMILIES for lv in levels]
        # no preload: the fork server must not import this module before it runs as the main one
        cals = run_parallel(calibration_job, jobs, args.workers, desc="calibrate", unit="effect")
        for c in cals:
            print(f"  seed {c['seed']} {c['family']:20s} {c['level']:g} sigma: attempt {c['attempt']}, "
                  f"gap {c['gap_um'] or 0:.4g} um, strength {c['strength'] or 0:.4g}, {c['status']}", file=sys.stderr)
        out["calibrations"] = cals
        out["forms_digest"] = forms_digest(cals)
        print(f"forms digest {out['forms_digest']} (levels {levels})")
    if args.manifest:
        args.manifest.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
