"""One watched session: follow the file, keep the model so far and the diagnosis up to date, and
publish what the page shows -- a JSON state and the SVG figures -- under a version number.

:meth:`SessionWatch.step` is called by the server's one publishing thread;
it reads what was flushed, collects finished worker jobs (a fit, a
diagnosis, a figure), publishes the state, and submits new jobs when a
worker is free: a refit, a diagnosis, the next figure whose data changed.  Request threads only read the published snapshot
(:meth:`SessionWatch.state_json`, :meth:`SessionWatch.figure`), so a page
is answered at once whatever is being drawn or fitted.
"""

from __future__ import annotations

import json
import math
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sessions.schema import Status

from ..output import jsonable
from ..plots.style import Quantity, display_unit, ratio_unit
from . import figures
from .progress import progress
from .refit import MIN_POINTS, ModelSoFar, RefitJob, WhereJob, WhereSoFar
from .tail import SessionTail
from .worker import Worker

#: A page that asked for the state within this many seconds is being looked at: keep its figures drawn.
VIEWED_S = 30.0
#: Longest wait for the first state of a session just opened (s).
FIRST_STATE_S = 5.0
#: Events of the log shown on the page (the latest).
EVENTS_SHOWN = 8
#: Fewest measured check points before the diagnosis is tried.
MIN_CHECK_POINTS = 20
#: The page's figures, in the order they are drawn when several are due.
FIGURE_ORDER = ("time", "loop", "model", "where")
#: Levels of the model so far when neither the session nor the options give a grid.
DEFAULT_LEVELS = 30
#: Fewest seconds between two diagnoses of the same pair of runs (each takes seconds of a core).
WHERE_INTERVAL_S = 10.0


@dataclass(frozen=True)
class WatchOptions:
    """How the page models the run.

    ``method`` of the model so far, re-fitted after every ``refit_every`` new
    measured points (and once more when the run ends); ``levels`` of its grid
    and of the diagnosis's (default: the session's own, else
    :data:`DEFAULT_LEVELS`; the range is the session's grid's, else the
    measured inputs');
    ``thermal_term`` asks for the ``c_d v`` term.  ``fit`` (the watched
    session is a check run of a model identified on this run) or ``check``
    (the watched session is an identification run; judge on this check run)
    turn on the diagnosis's "where" bins, once the other run exists.
    """

    method: str = "smooth_nn"
    levels: int | None = None
    refit_every: int = 5
    thermal_term: bool = True
    fit: Path | None = None
    check: Path | None = None


@dataclass
class Workers:
    """The worker processes shared by every watched session (:class:`~rig.watch.worker.Worker`): the
    model so far, the drawing, and the diagnosis (with ``fit`` or ``check`` only)."""

    refit: Worker
    draw: Worker
    where: Worker | None = None

    @classmethod
    def start(cls, options: WatchOptions) -> "Workers":
        """The workers ``options`` need (the fork server starts now, each worker process with its first job)."""
        from ..parallel import start_workers
        from .refit import refit, where

        diagnosing = options.fit is not None or options.check is not None
        preload = ("rig.diagnosis.loading",) if diagnosing else ()
        start_workers(("identify.fit", "rig.watch.refit", "rig.watch.figures", *preload))
        # drawing runs at the watch's own priority (the page waits for it); fits and diagnoses lower still
        return cls(Worker(refit), Worker(figures.Drawer(), nice=0),
                   Worker(where, preload=preload) if diagnosing else None)

    @property
    def busy(self) -> bool:
        return any(w is not None and w.busy for w in (self.refit, self.draw, self.where))

    def close(self) -> None:
        for w in (self.refit, self.draw, self.where):
            if w is not None:
                w.close()


class SessionWatch:
    """The live view of one session file (see the module doc)."""

    def __init__(self, path: Path, options: WatchOptions, workers: Workers) -> None:
        self.path = Path(path)
        self.options = options
        self.workers = workers
        self.tail = SessionTail(self.path)
        self.model: ModelSoFar | None = None
        self.model_error: str | None = None
        self.diagnosis: WhereSoFar | None = None
        self.viewed_at = -math.inf
        self._asked_fit = -1
        self._asked_where: tuple | None = None
        self._where_at = -math.inf
        self._figures: dict[str, tuple[int, bytes]] = {}
        self._drawn: dict[str, Any] = {}
        self._drawing: tuple[str, Any, int | None] | None = None
        self._shows: dict[str, int | None] = {}
        self._last_drawn: str | None = None
        self._results = 0  # numbers the models and diagnoses received, for the figures' keys
        self._model_no = self._diagnosis_no = 0
        self._version = 0
        self._state = b"{}"
        self._cond = threading.Condition()
        self._figure_count = 0

    # ------------------------------------------------------------------ reading side (request threads)
    @property
    def version(self) -> int:
        with self._cond:
            return self._version

    def look(self) -> bool:
        """A page is looking: keep the figures drawn.  True when they are not (the page just arrived)."""
        stale = time.monotonic() - self.viewed_at >= VIEWED_S
        self.viewed_at = time.monotonic()
        return stale

    def state_json(self, after: int | None = None, wait_s: float = 0.0) -> tuple[int, bytes]:
        """The published state (JSON bytes) and its version; with ``after``, wait up to ``wait_s`` for a
        newer one (a long poll: the page hears of a flushed sample as soon as it is published)."""
        end = time.monotonic() + wait_s
        first = time.monotonic() + FIRST_STATE_S
        with self._cond:
            while self._version == 0 and time.monotonic() < first:  # the first look at the file is under way
                self._cond.wait(first - time.monotonic())
            while after is not None and self._version <= after:
                left = end - time.monotonic()
                if left <= 0:
                    break
                self._cond.wait(left)
            return self._version, self._state

    def figure(self, name: str) -> tuple[int, bytes] | None:
        """The newest drawing of figure ``name`` and its version, or None before it is first drawn."""
        with self._cond:
            return self._figures.get(name)

    # ------------------------------------------------------------------ publishing side (one thread)
    def step(self, poll_file: bool = True, render: bool = True) -> bool:
        """Poll the file (when ``poll_file``) and the workers, submit jobs, publish; True when something
        changed.  The state is published before any figure is drawn, so the numbers are never held up
        by a drawing; each figure is published as the drawing worker finishes it."""
        changed = self.tail.poll() if poll_file else False
        changed |= self._collect()
        if changed or self._version == 0:
            self._publish()
        self._submit()
        if render and time.monotonic() - self.viewed_at < VIEWED_S:
            self._submit_drawing()
        return changed

    def _collect(self) -> bool:
        w = self.workers
        changed = False
        if w.refit.owner is self and (result := w.refit.result()) is not None:
            changed = True
            if isinstance(result, ModelSoFar) and result.error is None:
                self.model, self.model_error = result, None
                self._results += 1
                self._model_no = self._results
            else:
                self.model_error = result.error if isinstance(result, ModelSoFar) else str(result)
        if w.where is not None and w.where.owner is self and (result := w.where.result()) is not None:
            changed = True
            self.diagnosis = result if isinstance(result, WhereSoFar) else WhereSoFar(error=str(result))
            self._results += 1
            self._diagnosis_no = self._results
        if w.draw.owner is self and (result := w.draw.result()) is not None:
            name, key, shows = self._drawing
            self._drawing = None
            if isinstance(result, bytes):
                self._put(name, key, result)
                self._shows[name] = shows
                changed = True
            else:  # a figure that cannot be drawn is not tried again until its data change
                self._drawn[name] = key
        return changed

    def _grid(self) -> tuple[int, float, float] | None:
        header = self.tail.header
        if header is not None and header.grid is not None:
            g = header.grid
            return self.options.levels or g.levels, g.v_min, g.v_max
        s = self.tail.samples
        v = s["input"][s["measured"]]
        if v.size == 0 or not float(v.min()) < float(v.max()):
            return None
        return self.options.levels or DEFAULT_LEVELS, float(v.min()), float(v.max())

    def _submit(self) -> None:
        w, s, header = self.workers, self.tail.samples, self.tail.header
        if header is None:
            return
        n = s.size
        m = int(np.count_nonzero(s["measured"]))
        final = self.tail.status is not None and self.tail.status.final
        fitted = -1 if self.model is None else int(np.count_nonzero(s["measured"][: self.model.n_samples]))
        due = m >= MIN_POINTS and n != self._asked_fit and (
            m - fitted >= self.options.refit_every or (final and fitted < m) or self.model is None)
        grid = self._grid()
        if due and grid is not None and not w.refit.busy:
            q = header.quantities
            job = RefitJob(s["input"].copy(), np.where(s["measured"], s["output"], np.nan), *grid,
                           method=self.options.method, thermal_term=self.options.thermal_term,
                           input_unit=q.input_unit, output_unit=q.output_unit)
            if w.refit.submit(job, owner=self):
                self._asked_fit = n
        pair = self._where_pair()
        if pair is None or w.where is None or w.where.busy:
            return
        fit, check = pair
        try:
            other = (fit if check == self.path else check).stat()
        except OSError:
            return  # the other run does not exist yet
        key = (m, other.st_size, other.st_mtime_ns, str(self.tail.status))
        checks = m if check == self.path else None
        if key == self._asked_where or (checks is not None and checks < MIN_CHECK_POINTS):
            return
        if time.monotonic() - self._where_at < WHERE_INTERVAL_S and not final:
            return
        if w.where.submit(WhereJob(fit, check, self.options.levels), owner=self):
            self._asked_where, self._where_at = key, time.monotonic()

    def _where_pair(self) -> tuple[Path, Path] | None:
        o = self.options
        if o.fit is not None and o.fit.resolve() != self.path.resolve():
            return o.fit, self.path
        if o.check is not None and o.check.resolve() != self.path.resolve():
            return self.path, o.check
        return None

    def _quantities(self) -> tuple[Quantity, Quantity]:
        q = self.tail.header.quantities
        return Quantity(q.input_quantity, q.input_unit), Quantity(q.output_quantity, q.output_unit)

    def _figure_keys(self) -> dict[str, Any]:
        """What each figure would show now (None: nothing to draw yet); a figure whose key differs from
        the one it was drawn with is stale."""
        s = self.tail.samples
        n = s.size
        model = self.model if self.model is not None and self.model.n_samples <= n else None
        mkey = None if model is None else self._model_no
        d = self.diagnosis
        return {
            "time": (self.tail.generation, n, mkey) if n else None,
            "loop": (self.tail.generation, n, mkey) if s["measured"].any() else None,
            "model": mkey,
            "where": self._diagnosis_no if d is not None and d.diagnosis is not None else None,
        }

    def stale_figures(self) -> list[str]:
        """The figures whose data changed since they were drawn (or being drawn now), in drawing order."""
        if self.tail.header is None:
            return []
        keys = self._figure_keys()
        return [name for name in FIGURE_ORDER if keys[name] is not None and self._drawn.get(name) != keys[name]]

    def _submit_drawing(self) -> None:
        """Give the drawing worker, when free, the next stale figure (in turn, so that a figure redrawn at
        every sample does not starve the others)."""
        if self.workers.draw.busy:
            return
        stale = self.stale_figures()
        if not stale:
            return
        keys = self._figure_keys()
        n = self.tail.n_samples
        model = self.model if self.model is not None and self.model.n_samples <= n else None
        after = FIGURE_ORDER.index(self._last_drawn) + 1 if self._last_drawn in FIGURE_ORDER else 0
        name = min(stale, key=lambda f: (FIGURE_ORDER.index(f) - after) % len(FIGURE_ORDER))
        job = figures.DrawJob(name, self._figure_data(name, model))
        if self.workers.draw.submit(job, owner=self):
            d = self.diagnosis
            shows = {"time": n, "loop": n, "model": None if model is None else model.n_samples,
                     "where": None if d is None else d.n_check}[name]
            self._drawing, self._last_drawn = (name, keys[name], shows), name

    def _figure_data(self, name: str, model: ModelSoFar | None) -> dict[str, Any]:
        """The arguments of figure ``name``'s drawing function (:data:`figures.FIGURES`)."""
        s = self.tail.samples
        if name == "where":
            return {"diagnosis": self.diagnosis.diagnosis}
        vq, yq = self._quantities()
        n = s.size
        v, t = s["input"].copy(), s["t_s"].copy()
        y = np.where(s["measured"], s["output"], np.nan)
        if name == "time":
            pred = None
            if model is not None:
                pred = np.full(n, np.nan)
                pred[: model.n_samples] = model.prediction
            return {"t_s": t, "inputs": v, "outputs": y, "input_q": vq, "output_q": yq, "prediction": pred,
                    "title": self.path.name}
        if name == "loop":
            return {"inputs": v, "outputs": y, "input_q": vq, "output_q": yq,
                    "path": None if model is None else model.path,
                    "title": f"Hysteresis loop, {self.path.name}"}
        k = model.n_samples
        return {"inputs": v[:k], "outputs": y[:k], "prediction": model.prediction, "rows": model.rows,
                "input_q": vq, "output_q": yq,
                "title": f"Model so far: {model.method}, L = {model.levels}"}

    def _put(self, name: str, key, svg: bytes) -> None:
        with self._cond:
            self._figure_count += 1
            self._figures[name] = (self._figure_count, svg)
        self._drawn[name] = key

    def _publish(self) -> None:
        state = jsonable(self.build_state())
        with self._cond:
            self._version += 1
            state["version"] = self._version
            self._state = json.dumps(state, allow_nan=False).encode()
            self._cond.notify_all()

    # ------------------------------------------------------------------ the state the page shows
    def build_state(self) -> dict[str, Any]:
        """Everything the page shows but the figures, as a JSON-ready dict (see the README)."""
        tail, header = self.tail, self.tail.header
        with self._cond:
            figs = {name: v for name, (v, _) in self._figures.items()}
        state: dict[str, Any] = {
            "session": self.path.name,
            "path": str(self.path),
            "error": tail.error,
            "figures": figs,
            "drawn": dict(self._shows),
            "stale": self.stale_figures(),
            "updated_unix": time.time(),
        }
        if header is None:
            if not self.path.exists():
                text = f"waiting for {self.path.name} to be created (nothing has written it yet)"
            else:
                text = f"waiting: {tail.error}" if tail.error else "opening"
            state.update(status=None, status_text=text)
            return state
        s = tail.samples
        status = tail.status
        vq, yq = self._quantities()
        p = progress(header.excitation, s, tail.events, tail.writer_alive)
        e = header.excitation
        state.update(
            status=status.value if status else None,
            status_text=self._status_text(),
            writer_alive=tail.writer_alive,
            progress=p.to_dict(),
            started_at=header.started_at,
            clock=header.driver.get("clock"),
            operator=header.operator,
            notes=header.notes,
            excitation={"kind": e.kind, "levels": e.levels, "v_min": e.v_min, "v_max": e.v_max,
                        "thermal_term": e.thermal_term, "dwell": e.dwell.get("policy")},
            quantities={"input": vq.label, "output": yq.label, "input_unit": display_unit(vq.unit),
                        "output_unit": display_unit(yq.unit)},
            last=None,
            events=[{"t_unix": ev.t_unix, "status": ev.status.value, "event": ev.event, "message": ev.message,
                     "n_samples": ev.n_samples} for ev in tail.events[-EVENTS_SHOWN:]],
            model=self._model_state(vq, yq),
            where=self._where_state(),
        )
        if s.size:
            last = s[-1]
            state["last"] = {"index": int(last["index"]), "t_s": float(last["t_s"]),
                             "input": float(last["input"]),
                             "output": float(last["output"]) if last["measured"] else None}
        return state

    def _status_text(self) -> str:
        tail = self.tail
        status = tail.status
        if status is Status.RUNNING:
            text = "running: being written now" if tail.writer_alive else \
                "running, but no process is writing it (the writer stopped or died; rig acquire --resume continues it)"
        elif status is Status.COMPLETE:
            text = "complete"
        elif status is Status.ABORTED:
            text = "aborted (rig acquire --resume continues it)"
        elif status is Status.FAILED:
            last = tail.events[-1].message if tail.events else ""
            text = f"failed: {last}" if last else "failed"
        else:
            text = str(status)
        if tail.error:
            text += f" -- cannot read the file now: {tail.error}"
        return text

    def _model_state(self, vq: Quantity, yq: Quantity) -> dict[str, Any] | None:
        m, o = self.model, self.options
        n = self.tail.n_samples
        if m is None:
            measured = int(np.count_nonzero(self.tail.samples["measured"]))
            why = self.model_error or (f"waiting for {MIN_POINTS} measured points" if measured < MIN_POINTS
                                       else "fitting")
            return {"method": o.method, "status": why}
        return {
            "method": m.method, "status": "fitted", "levels": m.levels, "v_min": m.v_min, "v_max": m.v_max,
            "n_samples": m.n_samples, "n_used": m.n_used, "behind": max(0, n - m.n_samples),
            "thermal_term": m.thermal_term, "note": m.note, "rmse": m.rmse, "nrmse": m.nrmse,
            "max_abs": m.max_abs, "mu0": m.mu0, "c_d": m.c_d,
            "c_d_unit": ratio_unit(yq.unit, vq.unit), "seconds": m.seconds, "wall_s": m.wall_s,
            "error": self.model_error,
        }

    def _where_state(self) -> dict[str, Any] | None:
        pair = self._where_pair()
        if pair is None:
            return None
        fit, check = pair
        other = fit if check == self.path else check
        out: dict[str, Any] = {"fit": str(fit), "check": str(check)}
        d = self.diagnosis
        if d is None:
            out["status"] = (f"waiting for {other.name}" if not other.exists()
                             else "waiting for the first diagnosis")
            return out
        if d.error is not None:
            out.update(status=f"not yet: {d.error}")
            return out
        v = d.diagnosis.verdict
        out.update(status="diagnosed", n_check=d.n_check, verdict=v.status, effect=v.effect, reason=v.reason,
                   seconds=d.seconds, warnings=list(d.warnings))
        return out
