"""``rig watch``: a local web page that follows a session as it is written.

One module, one job:

* :mod:`rig.watch.tail` -- follow a session file read-only (SWMR), through
  its writer finishing, failing, dying and being resumed (a rewritten file);
* :mod:`rig.watch.progress` -- points, elapsed time, planned rig time, ETA;
* :mod:`rig.watch.refit` -- the model so far and the diagnosis's "where"
  bins, on a worker process that never blocks the page or the writer;
* :mod:`rig.watch.figures` -- the :mod:`rig.plots` figures as SVG;
* :mod:`rig.watch.watcher` -- one watched session: what the page shows,
  published under a version number;
* :mod:`rig.watch.server` -- the HTTP server (standard library, threaded),
  read-only, loopback by default, an access token beyond it;
* ``page/`` -- the HTML, script and style sheet (package data).
"""
