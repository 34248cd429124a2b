"""The withheld-forms benchmark of ``rig diagnose`` (issue 15); see ``benchmarks/withheld/README.md``.

Written from physical descriptions of the effects only, without reading the
diagnosis code or the simulator's built-in effects:

* :mod:`~benchmarks.withheld.physics` -- the effect families and the device that carries them;
* :mod:`~benchmarks.withheld.runs` -- identification and check runs through the real sequencer;
* :mod:`~benchmarks.withheld.generate` -- drawing the cases and calibrating their strengths;
* :mod:`~benchmarks.withheld.run` -- the blind runner and its tables.
"""
