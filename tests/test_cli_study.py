"""``rig study``: the JSON contract, worker-count independence, figures, bad input."""

import pytest

from .cli import assert_one_line_error, rig_here

SMALL = ("--levels", 8, "--measurements", 20, "--runs", 3, "--validation-points", 30)
METHOD_KEYS = {"model_rmse", "model_max", "density_rmse", "seconds", "validation_rmse", "failures"}


def _without_times(methods):
    return {name: {k: v for k, v in m.items() if k != "seconds"} for name, m in methods.items()}


@pytest.fixture(scope="module")
def two_worker_run():
    run = rig_here("study", "--profile", "gaussian", *SMALL, "--method", "ls", "--method", "cs_order_nn",
              "--method", "smooth_nn", "--workers", 2, "--json")
    assert run.code == 0, run.err
    return run.json()


def test_json_schema(two_worker_run):
    out = two_worker_run
    for key, want in (("profile", "gaussian"), ("levels", 8), ("measurements", 20), ("runs", 3),
                      ("noise", 10.0)):
        assert out[key] == want
    assert list(out["methods"]) == ["ls", "cs_order_nn", "smooth_nn"]
    for m in out["methods"].values():
        assert set(m) == METHOD_KEYS and m["failures"] == 0
        assert 0 < m["model_rmse"] <= m["model_max"] < 1 and m["seconds"] > 0
    assert out["n_points"] == 37 and out["sparsity"]["n"] == 37
    assert out["sweeps"] == {"measurements": [], "noise": []}
    assert out["paper"]["model_rmse"]["cs_order_nn"] == 0.0023  # Table 2
    assert all(f["verdict"] in ("agrees", "disagrees", "inconclusive", "met", "missed") for f in out["findings"])


@pytest.mark.slow
def test_results_do_not_depend_on_the_number_of_workers(two_worker_run):
    run = rig_here("study", "--profile", "gaussian", *SMALL, "--method", "ls", "--method", "cs_order_nn",
              "--method", "smooth_nn", "--workers", 1, "--json")
    assert run.code == 0, run.err
    assert _without_times(run.json()["methods"]) == _without_times(two_worker_run["methods"])


@pytest.mark.slow
def test_table_sweeps_and_figures(tmp_path):
    plots = tmp_path / "figs"
    run = rig_here("study", "--profile", "random", *SMALL, "--method", "ls", "--method", "cs",
              "--method", "smooth_nn", "--sweep-measurements", "10,30", "--sweep-noise", "0,20",
              "--plots", plots)
    assert run.code == 0, run.err
    text = run.out
    assert "paper_matlab_s" in text and "1.18" in text  # the paper's LS run time beside ours
    assert "Measurement sweep (figure 4b)" in text and "Noise sweep (figure 5a)" in text
    assert "CS models better than Least Squares" in text
    assert "Targets for Smooth Non-negative (ours)" in text
    names = sorted(p.name for p in plots.iterdir())
    assert names == ["errors.png", "fig3_dct.png", "fig4_measurements.png", "fig5a_noise.png"]
    for p in plots.iterdir():
        data = p.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


@pytest.mark.parametrize("args,fragment", [
    (("--runs", 0), "runs must be at least 1"),
    (("--measurements", 0), "between 1 and N=466"),
    (("--measurements", 467), "between 1 and N=466"),
    (("-L", 5, "-M", 17), "between 1 and N=16"),
    (("--profile", "lorentzian"), "lorentzian"),
    (("--method", "magic"), "magic"),
    (("--sweep-measurements", "10,abc"), "comma-separated"),
    (("--sweep-noise", "-5"), "noise amplitude"),
    (("--workers", 0), "workers"),
])
def test_bad_input_is_one_line_and_exit_2(args, fragment):
    assert_one_line_error(rig_here("study", *args), fragment)


def test_unwritable_plot_directory(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    run = rig_here("study", "-L", 3, "-M", 5, "--runs", 1, "--method", "ls", "--workers", 1,
              "--plots", blocker / "sub")
    assert_one_line_error(run, "cannot write the figures")
