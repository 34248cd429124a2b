"""All ``rig`` subcommands, one module each; add new ones to :data:`COMMANDS`."""

from .acquire import acquire
from .bench import bench
from .demo import demo
from .diagnose import diagnose
from .export import export
from .identify import identify
from .import_ import import_
from .predict import predict
from .report import report
from .selftest import selftest
from .serve_sim import serve_sim
from .study import study
from .validate import validate
from .watch import watch

COMMANDS = [demo, identify, predict, import_, export, selftest, serve_sim, acquire, validate, report, study, bench,
            diagnose, watch]
