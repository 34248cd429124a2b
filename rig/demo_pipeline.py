"""The whole job on the embedded simulated rig: acquire -> identify -> diagnose -> report.

What ``rig demo`` runs, in the order an operator and a researcher would:

1. **acquire** -- an identification run (the damped oscillation of the grid
   with the thermal point) and a held-out check run (``rig acquire
   --sequence check``: random reversals, several steps and dwells) on the
   simulated VO2 device, through the real sequencer and its virtual clock,
   into two session files (:mod:`rig.diagnosis.simulate`).  One unmodelled
   effect is switched on in the device (``creep`` unless told otherwise),
   as a real cantilever has them;
2. **identify** -- every demo method on ``M`` randomly chosen measured
   points of the identification session, each model stored in the session
   (``/models/NAME``, as ``rig identify`` names them) and scored on the
   check session;
3. **diagnose** -- ``rig diagnose --fit fit.h5 --check check.h5``: where the
   model misses on the check run, which effect causes it, how far the gap
   shrinks with it (figures ``diagnosis/where.png``, ``candidates.png``);
4. **report** -- ``rig report fit.h5 --model smooth_nn-... --check check.h5``
   into ``report/`` (figures and ``report.md``).

Nothing here is a shortcut past the application: the same functions run
behind ``rig acquire``, ``rig identify``, ``rig diagnose`` and ``rig report``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from identify import Excitation
from sessions import ModelRecord
from sessions.recording import Recording

from .diagnosis.demo import demo_strength, diagnose_sessions
from .diagnosis.report import write_figures
from .diagnosis.simulate import SimulatedBench, simulate_check_run, simulate_fit_run
from .errors import UserError
from .reidentify import IdentifyOptions, fit_job, plan_job, store_model
from .model_scoring import score_model
from .session_input import open_run

#: The methods the demo identifies with, in the order it prints them.
DEMO_METHODS = ("ls", "cs", "cs_order", "cs_order_nn", "smooth_nn")
#: The method whose model the report shows (ours; see docs/results/2026-11-21-simulation-study.md).
REPORT_METHOD = "smooth_nn"
#: Session file names inside the demo directory.
FIT_SESSION, CHECK_SESSION = "fit.h5", "check.h5"


@dataclass(frozen=True)
class DemoSettings:
    """What to simulate and identify: grid ``levels``, ``measurements`` M of the identification
    run's points (None: all), the ``effect`` switched on (None: none) at ``strength`` (None: the
    calibrated demo strength, about ten times the noise level), the check run's length, the seed."""

    levels: int = 30
    measurements: int | None = 300
    effect: str | None = "creep"
    strength: float | None = None
    check_points: int = 200
    seed: int = 0
    methods: tuple[str, ...] = DEMO_METHODS

    @property
    def effect_strength(self) -> float:
        if self.effect is None:
            return 0.0
        return demo_strength(self.effect) if self.strength is None else float(self.strength)


@dataclass(eq=False)
class DemoResult:
    """Everything the demo did, with the paths of what it wrote."""

    settings: DemoSettings
    out: Path
    fit_path: Path
    check_path: Path
    fit_points: int = 0
    check_points: int = 0
    acquire_seconds: float = 0.0
    methods: list[dict[str, Any]] = field(default_factory=list)
    diagnosis_text: str = ""
    diagnosis: dict[str, Any] = field(default_factory=dict)
    report_path: Path | None = None
    figures: list[Path] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        s = self.settings
        return {
            "levels": s.levels,
            "measurements": s.measurements,
            "points": self.fit_points,
            "check_points": self.check_points,
            "effect": s.effect,
            "strength": s.effect_strength,
            "seed": s.seed,
            "out": str(self.out),
            "sessions": {"fit": str(self.fit_path), "check": str(self.check_path)},
            "acquire_s": self.acquire_seconds,
            "methods": self.methods,
            "diagnosis": self.diagnosis,
            "report": None if self.report_path is None else str(self.report_path),
            "figures": [str(p) for p in self.figures],
        }


#: What a demo writes into ``--out``: its two sessions and its two folders of figures.
WRITTEN = (FIT_SESSION, CHECK_SESSION, "report", "diagnosis")


def _fresh(out: Path, force: bool = False) -> list[Path]:
    """Refuse a directory that already holds anything a demo writes -- nothing the user has is overwritten
    -- unless ``force``; returns an earlier demo's sessions that ``force`` will replace (removed only when
    the new run starts: bad input never costs them) -- its figures are written over."""
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: is a file, not a directory")
    there = [name for name in WRITTEN if (out / name).exists() or (out / name).is_symlink()]
    if there and not force:
        raise UserError(f"--out {out}: already holds {', '.join(there)} from an earlier run; nothing is "
                        "overwritten -- choose another --out, or add --force to replace them")
    sessions = [out / name for name in (FIT_SESSION, CHECK_SESSION) if name in there]
    for path in sessions:
        if path.is_dir():
            raise UserError(f"--out {out}: {path.name} is a directory; it was not replaced")
    return sessions


def _bench(s: DemoSettings) -> SimulatedBench:
    return SimulatedBench(s.effect, s.effect_strength, levels=s.levels, check_points=s.check_points, seed=s.seed)


def acquire_step(s: DemoSettings, result: DemoResult) -> None:
    """Record both runs; if the simulated rig fails (an effect so strong that the PSD saturates),
    remove what this run wrote -- demo sessions, not data -- so that ``--out`` can be used again,
    and say which setting caused it (exit 2: the simulated device did what it was told)."""
    from drivers.errors import DriverError

    bench = _bench(s)
    t0 = time.perf_counter()
    try:
        simulate_fit_run(bench, result.fit_path)
        simulate_check_run(bench, result.check_path)
    except DriverError as exc:
        for path in (result.fit_path, result.check_path):
            path.unlink(missing_ok=True)
        setting = f"--with {s.effect} --strength {s.effect_strength:g}" if s.effect else "the ideal device"
        raise UserError(f"{setting}: the simulated rig cannot record the demo's runs ({exc}); nothing was "
                        f"kept in {result.out}; choose a smaller --strength (the demo's own: "
                        f"{demo_strength(s.effect):g})") from None
    result.acquire_seconds = time.perf_counter() - t0


def identify_step(s: DemoSettings, check: Recording, result: DemoResult) -> ModelRecord:
    """Fit, store and score on ``check`` every method; returns the record of the report's model."""
    shown = None
    for method in s.methods:
        job = plan_job(result.fit_path, IdentifyOptions(method=method, measurements=s.measurements, seed=s.seed))
        report = fit_job(job)
        record = store_model(job, report, force=False)
        score = score_model(record, check)
        result.methods.append({
            "method": method,
            "name": job.store_as,
            "fit_rmse_um": report.rmse,
            "validation_rmse_um": score.rmse,
            "validation_nrmse": score.nrmse,
            "seconds": report.seconds,
        })
        if method == REPORT_METHOD or shown is None:
            shown = record
        result.fit_points = int(job.inputs.size)
    return shown


def diagnose_step(out: Path, result: DemoResult) -> None:
    diagnosis, result.diagnosis_text, result.diagnosis = diagnose_sessions(result.fit_path, result.check_path)
    result.figures += write_figures(diagnosis, out / "diagnosis")


def report_step(record: ModelRecord, check: Recording, out: Path, result: DemoResult) -> None:
    from .session_report import SUMMARY, build_report, score_runs, write_report

    fitted, checked = score_runs(record, open_run(result.fit_path, allow_partial=False), check)
    built = build_report(fitted, record, checked)
    written = write_report(built, out / "report")
    result.report_path = out / "report" / SUMMARY
    result.figures += [p for p in written if p.suffix == ".png"]


def run_demo(settings: DemoSettings, out: str | Path,
             progress: Callable[[str], None] | None = None, force: bool = False) -> DemoResult:
    """Acquire, identify, diagnose and report into the directory ``out`` (created; refused when it
    already holds anything a demo writes, unless ``force``).  ``progress`` is called with each step's name
    as it starts."""
    step = progress or (lambda name: None)
    out = Path(out)
    replaced = _fresh(out, force)
    points = Excitation.damped(_bench(settings).grid(), True).inputs.size
    if settings.measurements is not None and not 1 <= settings.measurements <= points:
        raise UserError(f"--measurements {settings.measurements} must be between 1 and the {points} points "
                        f"of the damped oscillation at L={settings.levels}")
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    for path in replaced:
        path.unlink()
    result = DemoResult(settings, out, out / FIT_SESSION, out / CHECK_SESSION)
    try:
        step("1/4 acquiring")
        acquire_step(settings, result)
    except UserError:
        if created and not any(out.iterdir()):
            out.rmdir()
        raise
    check = open_run(result.check_path, allow_partial=False)
    result.check_points = int(check.inputs.size)
    step("2/4 identifying")
    shown = identify_step(settings, check, result)
    step("3/4 diagnosing")
    diagnose_step(out, result)
    step("4/4 reporting")
    report_step(shown, check, out, result)
    return result
