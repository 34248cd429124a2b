"""Safety rules: limits checked before any write, rounding never crosses a limit, Ctrl-C guards, 0 V on exit."""

from __future__ import annotations

import math
import os
import signal

import pytest

from drivers import LimitError, Reading, SensorError, open_rig
from drivers.channels import GuardedHeater, PSDSensor
from interrupts import delay_keyboard_interrupt, terminate_as_interrupt
from drivers.limits import CurrentLimit, FiniteSetpoint, HeaterLimits, VoltageRange
from drivers.protocols import Calibration, DeflectionSensor, HeaterOutput


class RecordingHeater(GuardedHeater):
    """A heater whose 'instrument' is a list: what was written, in order."""

    def __init__(self, limits, step=None):
        super().__init__(limits)
        self.wire: list[float] = []
        self.step = step

    def _on_wire(self, volts):
        return volts if self.step is None else round(volts / self.step) * self.step

    def _write_voltage(self, volts):
        self.wire.append(volts)

    def _read_voltage(self):
        return self.wire[-1] if self.wire else 0.0


class ScriptedPSD(PSDSensor):
    def __init__(self, values, **kw):
        super().__init__(Calibration(5.0, 0.1), **kw)
        self.values = list(values)
        self.calls = 0

    def _read_psd(self):
        self.calls += 1
        return self.values.pop(0)


def test_each_limit_says_why():
    assert FiniteSetpoint().refuses(1.0) is None
    assert "not finite" in FiniteSetpoint().refuses(math.nan)
    assert "not finite" in FiniteSetpoint().refuses(-math.inf)
    assert "not a number" in FiniteSetpoint().refuses("1.0")
    r = VoltageRange(0.0, 6.0)
    assert r.refuses(0.0) is None and r.refuses(6.0) is None
    assert "outside" in r.refuses(6.0000001) and "outside" in r.refuses(-0.1)
    c = CurrentLimit(12.78, 682.5, 100.0)  # the paper's 12.78 mA through 782.5 ohm: about 10 V
    assert c.max_V == pytest.approx(12.78e-3 * 782.5)
    assert c.refuses(10.0) is None and c.refuses(c.max_V) is None
    assert "mA" in c.refuses(10.01)
    assert c.current_mA(-5.0) == pytest.approx(5.0 / 782.5 * 1e3)


def test_current_limit_narrows_the_window():
    limits = HeaterLimits.build(0.0, 12.0, max_current_mA=12.78, series_resistance_ohm=682.5)
    # Heater resistance unknown: the conservative bound uses the series resistor alone.
    assert limits.window.max_V == pytest.approx(12.78e-3 * 682.5)
    assert limits.window.min_V == 0.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 6.5, -0.01, 9.0])
def test_refused_setpoints_never_reach_the_instrument(bad):
    heater = RecordingHeater(HeaterLimits.build(0.0, 6.0, 10.0, 500.0))  # current limit: 5 V
    heater.set_voltage(2.0)
    with pytest.raises(LimitError) as info:
        heater.set_voltage(bad)
    assert heater.wire == [2.0]
    assert heater.last_written == 2.0
    assert info.value.check in {"finite", "voltage", "current"}


def test_numpy_scalars_are_numbers():
    import numpy as np

    heater = RecordingHeater(HeaterLimits.build(0.0, 6.0))
    heater.set_voltage(np.float32(1.5))
    heater.set_voltage(np.float64(2.5))
    assert heater.wire == [1.5, 2.5]
    with pytest.raises(LimitError):
        heater.set_voltage(np.float32("nan"))


def test_rounding_on_the_wire_cannot_cross_a_limit():
    heater = RecordingHeater(HeaterLimits.build(0.0, 5.9996), step=0.001)
    heater.set_voltage(5.9994)  # rounds down to 5.999: fine
    assert heater.wire == [pytest.approx(5.999)]
    with pytest.raises(LimitError, match="on the wire"):
        heater.set_voltage(5.9996)  # allowed as asked, but the instrument would get 6.000
    assert len(heater.wire) == 1


def test_heater_limits_must_allow_the_safe_state():
    with pytest.raises(ValueError, match="0 V"):
        RecordingHeater(HeaterLimits.build(1.0, 6.0))


def test_sensor_retries_nan_and_saturation_then_gives_a_clear_error():
    s = ScriptedPSD([math.nan, 9.95, 1.1], saturation_V=9.9, retries=2)
    reading = s.read()
    assert reading == Reading((1.1 - 0.1) * 5.0, 1.1, Calibration(5.0, 0.1), retried=True)  # flags READ_RETRIED
    assert s.calls == 3
    assert ScriptedPSD([1.2], saturation_V=9.9).read().retried is False
    s = ScriptedPSD([math.nan, -10.0, math.nan], saturation_V=9.9, retries=2)
    with pytest.raises(SensorError, match="3 attempts.*NaN|3 attempts.*nan"):
        s.read()
    s = ScriptedPSD([10.0, 10.0], saturation_V=9.9, retries=1)
    with pytest.raises(SensorError, match="saturated"):
        s.read()


def test_retries_back_off_exponentially_and_name_the_last_failure():
    from drivers import ConnectionFailed, DriverTimeout, ProtocolError
    from drivers.retry import Backoff, BadReply, LinkDropped, NoReply, with_retries

    assert Backoff(5, 0.1, 1.0).delays() == pytest.approx([0.1, 0.2, 0.4, 0.8, 1.0])
    for failure, error in [(LinkDropped, ConnectionFailed), (NoReply, DriverTimeout), (BadReply, ProtocolError)]:
        slept, reconnects, calls = [], [], []

        def attempt():
            calls.append(1)
            raise failure("boom")

        with pytest.raises(error, match="reading x: .*(boom.*3 attempt|3 attempt.*boom)"):
            with_retries(attempt, reconnect=lambda: reconnects.append(1), backoff=Backoff(2, 0.05, 1.0),
                         what="reading x", sleep=slept.append)
        assert slept == [0.05, 0.1] and len(reconnects) == 2 and len(calls) == 3

    outcomes = iter([LinkDropped("down"), NoReply("late"), "ok"])

    def flaky():
        out = next(outcomes)
        if isinstance(out, Exception):
            raise out
        return out

    assert with_retries(flaky, reconnect=lambda: None, backoff=Backoff(3, 0.0, 0.0), what="x", sleep=lambda s: None) == "ok"


def test_backends_satisfy_the_protocols():
    with open_rig() as rig:
        assert isinstance(rig.heater, HeaterOutput)
        assert isinstance(rig.sensor, DeflectionSensor)
    assert not isinstance(object(), HeaterOutput)


def test_delayed_interrupt_lets_the_block_finish_then_raises():
    done = []
    with pytest.raises(KeyboardInterrupt):
        with delay_keyboard_interrupt():
            os.kill(os.getpid(), signal.SIGINT)
            done.append("transaction complete")
    assert done == ["transaction complete"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_second_interrupt_is_held_too_and_sigterm_as_well(capfd):
    done, seen = [], []
    with pytest.raises(KeyboardInterrupt):
        with delay_keyboard_interrupt():
            os.kill(os.getpid(), signal.SIGINT)
            os.kill(os.getpid(), signal.SIGINT)
            done.append("transaction complete")  # the operator's second Ctrl-C waits for it too
    assert done == ["transaction complete"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    old = signal.signal(signal.SIGINT, lambda signum, frame: seen.append(signum))
    try:
        with delay_keyboard_interrupt():
            os.kill(os.getpid(), signal.SIGINT)
            os.kill(os.getpid(), signal.SIGINT)
            assert seen == []
        assert seen == [signal.SIGINT, signal.SIGINT]  # every one delivered, in order, to the handler before
    finally:
        signal.signal(signal.SIGINT, old)
    with pytest.raises(KeyboardInterrupt):
        with terminate_as_interrupt(), delay_keyboard_interrupt():
            os.kill(os.getpid(), signal.SIGTERM)
            done.append("finished first")
    assert done == ["transaction complete", "finished first"]
    assert capfd.readouterr().err == ""  # silent: whoever handles the signal reports it


def test_sigterm_becomes_an_interrupt_only_inside_the_guard():
    old = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt):
        with terminate_as_interrupt():
            os.kill(os.getpid(), signal.SIGTERM)
    assert signal.getsignal(signal.SIGTERM) == old


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt()])
def test_rig_returns_the_heater_to_zero_on_any_exception(exc):
    with pytest.raises(type(exc)):
        with open_rig() as rig:
            rig.heater.set_voltage(4.0)
            rig.clock.sleep(60)
            assert rig.device.state().temperature_C > 60
            raise exc
    assert rig.device.applied_voltage == 0.0
    assert rig.device.setpoints[-1][1] == 0.0
    assert rig.closed


def test_opening_a_rig_puts_the_heater_at_zero():
    from drivers.clock import VirtualClock
    from drivers.sim import SimVO2

    clock = VirtualClock()
    device = SimVO2(clock=clock)
    device.apply_voltage(3.0)
    with open_rig(device=device) as rig:
        assert rig.clock is clock
        assert rig.device is device
        assert device.applied_voltage == 0.0
    assert [v for _, v in device.setpoints] == [3.0, 0.0, 0.0]


class FlakyHeater(RecordingHeater):
    """A heater whose instrument stops acknowledging writes (``dead``) or reads back ``stuck_at``."""

    def __init__(self, limits):
        super().__init__(limits)
        self.dead = False
        self.stuck_at = None

    def _write_voltage(self, volts):
        from drivers import ConnectionFailed

        if self.dead:
            raise ConnectionFailed("refused or unreachable")
        super()._write_voltage(volts)

    def _read_voltage(self):
        return self.stuck_at if self.stuck_at is not None else super()._read_voltage()


def test_the_safe_state_is_confirmed_only_when_0V_is_acknowledged_and_read_back():
    heater = FlakyHeater(HeaterLimits.build(0.0, 6.0))
    heater.set_voltage(3.5)
    state = heater.safe_state()
    assert state.confirmed and state.acknowledged and state.readback_V == 0.0 and heater.wire == [3.5, 0.0]
    assert state.describe().startswith("heater at 0 V")
    assert heater.safe_state() is state and heater.wire == [3.5, 0.0]  # nothing written since: it stands
    heater.set_voltage(4.25)
    heater.dead = True
    with pytest.raises(Exception):
        heater.set_voltage(5.0)  # sent, never acknowledged
    state = heater.safe_state()
    assert not state.confirmed and not state.acknowledged and (state.last_V, state.unacknowledged_V) == (4.25, 5.0)
    text = state.describe()
    assert "heater at 0 V" not in text and "UNKNOWN" in text and "4.25 V" in text and "5 V" in text
    heater.dead, heater.stuck_at = False, 4.25  # acknowledges 0 V but the output stays on
    state = heater.safe_state()
    assert not state.confirmed and state.acknowledged and state.readback_V == 4.25
    assert "reads back 4.25 V" in state.describe()
