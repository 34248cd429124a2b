"""Drive the rig by hand: heater, sensor and clock, the three small protocols the sequencer sees.

    python examples/rig_by_hand.py [rig.toml]

Without a configuration it opens the built-in simulated device on its virtual clock, where an
hour of dwell is one addition. With a ``rig.toml`` it drives that instrument, so mind the limits:
they are checked before anything reaches the wire, and the heater returns to 0 V on closing.
"""

# %% Open the rig
import sys

from drivers import default_config, load_config, open_rig

config = load_config(sys.argv[1]) if len(sys.argv) > 1 else default_config()

# %% A staircase up and down, reading the deflection after each dwell
readings = []
with open_rig(config) as rig:
    for volts in (0.0, 2.0, 4.0, 6.0, 4.0, 2.0, 0.0):
        rig.heater.set_voltage(volts)
        rig.clock.sleep(10.0)
        r = rig.sensor.read()
        readings.append((volts, r.deflection_um))
        print(f"{volts:4.1f} V -> {r.deflection_um:8.3f} um (PSD {r.psd_V:.4f} V)")
print(rig.heater_state)  # what is known about the heater after closing

# %% Hysteresis: the same voltage reads differently on the way up and on the way down
up, down = readings[2][1], readings[4][1]  # 4 V lies inside the transition of the simulated VO2
print(f"at 4 V: {up:.3f} um rising, {down:.3f} um falling")
assert abs(up - down) > 0.1
