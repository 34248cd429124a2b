"""``rig bench``: the fast path against the dense reference, on the same simulated problems."""

from __future__ import annotations

import click
from tqdm import tqdm

from identify.methods import DAMPED_METHODS

from ..bench.cases import DEFAULT_CASES, Case, parse_case
from ..bench.runner import bench as run_bench
from ..errors import UserError
from ..options import AliasedOption
from ..output import format_table, print_json


def _cases(texts: tuple[str, ...]) -> list[Case]:
    if not texts:
        return [Case(levels, m) for levels, m in DEFAULT_CASES]
    try:
        return [parse_case(t) for t in texts]
    except ValueError as exc:
        raise UserError(str(exc)) from None


@click.command()
@click.option("--case", "cases", multiple=True, metavar="L:M",
              help="Levels and measurements (repeatable). Default: 30:300, 100:3284, 200:13000.")
@click.option("--method", "methods", multiple=True, type=click.Choice(list(DAMPED_METHODS)),
              help="Methods to run (repeatable). Default: every method that applies to the simulated "
                   "damped-oscillation runs (all but everett, which needs FORC data).")
@click.option("--dense-up-to", type=click.IntRange(0), default=30, show_default=True,
              help="Run the dense reference for cases with at most this many levels.")
@click.option("--repeats", type=click.IntRange(1), default=5, show_default=True,
              help="Timed runs per measurement (the median is reported).")
@click.option("--budget", "budget_s", cls=AliasedOption, aliases=("--budget-s",),
              type=click.FloatRange(min=0), default=60.0, show_default=True, metavar="SECONDS",
              help="Stop repeating a measurement once its runs took this long (at least one run).")
@click.option("--timeout", "timeout_s", cls=AliasedOption, aliases=("--timeout-s",),
              type=click.FloatRange(min=1), default=900.0, show_default=True, metavar="SECONDS",
              help="Give up on one measurement after this long.")
@click.option("--threads", type=click.IntRange(1), default=None,
              help="BLAS threads in the measuring processes (default: one for a problem of at most 2,100 "
                   "parameters, L <= 63; the library's own for a larger one).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def bench(cases, methods, dense_up_to, repeats, budget_s, timeout_s, threads, as_json):
    """Time every identification method, fast path and dense reference, on simulated data.

    Each measurement runs in a fresh process: end-to-end time (problem
    building plus fit, median of the runs), peak memory (ru_maxrss of that
    process, MB), and the accuracy of the fast result against the dense one.
    """
    chosen = list(methods) or list(DAMPED_METHODS)
    plan = _cases(cases)
    rows = []
    with tqdm(total=len(plan) * len(chosen), desc="bench", unit="case", disable=None) as bar:
        for case in plan:
            for method in chosen:
                bar.set_postfix_str(f"L={case.levels} {method}")
                rows.extend(run_bench([case], [method], dense_up_to, repeats, budget_s, timeout_s, threads))
                bar.update()
    if as_json:
        print_json({"cases": rows})
        return
    headers = ["L", "M", "method", "fast_s", "dense_s", "ratio", "peak_mb", "rmse_rel_diff", "status"]
    click.echo(format_table(headers, [
        [r["levels"], r["measurements"], r["method"], _num(r["fast_s"]), _num(r["dense_s"]),
         _num(r["ratio"]), _num(r["peak_mb"]), _num(r["rmse_rel_diff"]), r["status"]]
        for r in rows
    ]))


def _num(x):
    return float("nan") if x is None else x
