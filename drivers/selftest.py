"""``rig selftest``: connect, read, apply a small safe voltage, read back, return to 0 V.

:func:`selftest` returns the report (no printing); ``passed`` is true only
when every step passed.  Keys (a contract): ``driver``, ``connected``,
``heater_ok``, ``sensor_ok``, ``deflection_um``, ``safe_state``; also
``passed``, ``endpoint``, ``test_voltage_V``, ``readback_V``, ``psd_V``,
``deflection_heated_um``, ``error``, ``seconds`` and ``safe_state_V`` (the
heater read back after 0 V was written; null when it was not read); and the window check:
``window_V`` (the set-points the heater accepts, ``[min, max]``),
``full_scale_V`` (the instrument's, when it or the configuration says;
null otherwise) and ``window_ok`` (false when the window reaches beyond
the full scale: a run would be refused, or refused mid-way by the
instrument).
"""

from __future__ import annotations

import time
from typing import Any

from .config import RigConfig, default_config
from .errors import DriverError, InstrumentBusy
from .protocols import Clock
from .rig import open_rig
from .setpoint_rules import same_setpoint


def selftest(config: RigConfig | None = None, *, clock: Clock | None = None) -> dict[str, Any]:
    """Run the self-test on the rig of ``config`` (default: the built-in simulated device)."""
    cfg = config if config is not None else default_config()
    volts = cfg.heater.selftest_V
    report: dict[str, Any] = {
        "driver": cfg.driver,
        "connected": False,
        "heater_ok": False,
        "sensor_ok": False,
        "deflection_um": None,
        "safe_state": False,
        "passed": False,
        "endpoint": None,
        "test_voltage_V": volts,
        "readback_V": None,
        "psd_V": None,
        "deflection_heated_um": None,
        "error": None,
        "seconds": None,
        "window_V": None,
        "full_scale_V": None,
        "window_ok": False,
        "safe_state_V": None,
    }
    errors: list[str] = []
    start = time.perf_counter()
    try:
        rig = open_rig(cfg, clock=clock)
    except InstrumentBusy:
        raise  # another run is using the instrument: not a failed check, a refusal (exit 2)
    except DriverError as exc:
        report["error"] = str(exc)
        report["seconds"] = time.perf_counter() - start
        return report
    report["connected"] = True
    report["endpoint"] = rig.description.get("endpoint")
    window, full_scale = rig.heater.window, rig.heater.full_scale_V
    report.update(window_V=[window.min_V, window.max_V], full_scale_V=full_scale)
    report["window_ok"] = full_scale is None or max(abs(window.min_V), abs(window.max_V)) <= full_scale * (1 + 1e-12)
    if not report["window_ok"]:
        errors.append(f"window: the heater's window [{window.min_V:g}, {window.max_V:.9g}] V reaches beyond the "
                      f"instrument's full scale of +-{full_scale:g} V: lower [heater] max_V (or max_current_mA) to fit it")
    try:
        with rig:
            try:
                reading = rig.sensor.read()
                report.update(sensor_ok=True, deflection_um=reading.deflection_um, psd_V=reading.psd_V)
            except DriverError as exc:
                errors.append(f"sensor: {exc}")
            try:
                rig.heater.set_voltage(volts)
                sent = rig.heater.last_written
                back = rig.heater.read_voltage()
                report["readback_V"] = back
                report["heater_ok"] = sent is not None and same_setpoint(back, sent)
                if not report["heater_ok"]:
                    errors.append(f"heater: set {volts:g} V but read back {back:g} V")
                if report["sensor_ok"]:
                    report["deflection_heated_um"] = rig.sensor.read().deflection_um
            except DriverError as exc:
                errors.append(f"heater: {exc}")
            try:
                rig.zero()
                back0 = rig.heater.read_voltage()
                report["safe_state_V"] = back0
                report["safe_state"] = same_setpoint(back0, 0.0)
                if not report["safe_state"]:
                    errors.append(f"safe state: heater reads {back0:g} V after being set to 0 V")
            except DriverError as exc:
                errors.append(f"safe state: {exc}")
    except DriverError as exc:  # closing could not confirm 0 V
        report["safe_state"] = False
        errors.append(str(exc))
    report["error"] = "; ".join(errors) or None
    report["passed"] = bool(report["connected"] and report["heater_ok"] and report["sensor_ok"] and report["safe_state"]
                            and report["window_ok"])
    report["seconds"] = time.perf_counter() - start
    return report
