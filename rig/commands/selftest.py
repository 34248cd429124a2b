"""``rig selftest``: check that the rig answers and returns to its safe state."""

from __future__ import annotations

from pathlib import Path

import click

from drivers.config import load_config
from interrupts import terminate_as_interrupt
from drivers.selftest import selftest as run_selftest

from ..errors import EXIT_RIG_FAULT
from ..output import format_table, print_json


def _fmt(value, unit: str) -> str:
    return "-" if value is None else f"{value:.4g} {unit}"


def _window(window, full_scale) -> str:
    if window is None:
        return "-"
    scale = "unknown" if full_scale is None else f"+-{full_scale:g} V"
    return f"[{window[0]:g}, {window[1]:.6g}] V within the instrument's full scale ({scale})"


def _safe_detail(report: dict) -> str:
    """What is known about the 0 V at the end -- never "read back at 0 V" unless it was."""
    back = report.get("safe_state_V")
    if report["safe_state"]:
        return "heater read back at 0 V"
    if not report["connected"]:
        return "nothing was driven or read"
    return "-" if back is None else f"heater reads back {back:g} V after 0 V was written"


@click.command()
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=Path),
              help="rig.toml (default: the built-in simulated device).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def selftest(config_path, as_json):
    """Connect, read the sensor, apply a small safe voltage, read it back, return to 0 V.

    Exit code 0 only when every check passed, 3 when one failed (as for any fault of the instrument or its
    link; docs/reference/exit-codes.md).
    """
    cfg = load_config(config_path) if config_path else None
    with terminate_as_interrupt():
        report = run_selftest(cfg)
    if as_json:
        print_json(report)
    else:
        ran = report["connected"]

        def ok(flag: bool) -> str:
            return "ok" if flag else "FAILED" if ran else "not run"

        rows = [
            ["connected", "ok" if ran else "FAILED", report["endpoint"] or "-"],
            ["sensor", ok(report["sensor_ok"]),
             f"deflection {_fmt(report['deflection_um'], 'um')}, PSD {_fmt(report['psd_V'], 'V')}"],
            ["heater", ok(report["heater_ok"]),
             f"set {_fmt(report['test_voltage_V'], 'V')}, read back {_fmt(report['readback_V'], 'V')}"],
            ["safe state", ok(report["safe_state"]), _safe_detail(report)],
            ["window", ok(report["window_ok"]), _window(report["window_V"], report["full_scale_V"])],
        ]
        click.echo(f"rig selftest, driver '{report['driver']}':")
        click.echo(format_table(["check", "result", "detail"], rows))
        click.echo("PASSED" if report["passed"] else f"FAILED: {report['error']}")
    raise click.exceptions.Exit(0 if report["passed"] else EXIT_RIG_FAULT)
