"""indicial.predict equals `indicial predict` (runtime over a run's motion, and --periodic)."""
import csv

import numpy as np
import pytest

import indicial


def read_csv(path):
    rows = [r for r in csv.reader(l for l in open(path) if not l.startswith("#"))]
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


@pytest.mark.parametrize("periodic", [False, True])
def test_predict_equals_cli(case_dir, cli_fit, cli, tmp_path, periodic):
    run_file = sorted(case_dir.glob("run_*.csv"))[-1]
    out = tmp_path / "pred.csv"
    cli("predict", cli_fit / "model.coef", run_file, "--out", out, *(["--periodic"] if periodic else []))
    expected = read_csv(out)
    e = indicial.Experiment.from_toml(str(case_dir / "experiment.toml"))
    run = next(r for r in e.runs if r["name"].endswith(run_file.name))
    model = indicial.Model.load(str(cli_fit / "model.coef"))
    p = indicial.predict(model, time_s=run["time_s"], alpha_rad=run["motion_angle_rad"], q_radps=run["rate_radps"],
                         periodic=periodic, measured={"Cm": run["coefficient"]})
    for key, got in (("Cm_pred", p.predicted["Cm"]), ("Cm_quasi_steady", p.quasi_steady["Cm"])):
        assert np.all(np.abs(got - expected[key]) <= 1e-12 * np.maximum(1.0, np.abs(expected[key]))), key
    m = p.metrics["Cm"]["model"]
    assert m["n_samples"] == len(run["time_s"]) and 0 < m["theil_inequality"] < 0.1
    # Theil's decomposition, as the CLI's metrics file writes it.
    e = p.predicted["Cm"] - np.asarray(run["coefficient"])
    assert abs(m["mean_error"] - e.mean()) <= 1e-12 and abs(m["rms_about_mean"] - e.std()) <= 1e-12
    assert abs(m["rms_error"] ** 2 - m["mean_error"] ** 2 - m["rms_about_mean"] ** 2) <= 1e-12
    assert abs(m["bias_proportion"] - m["mean_error"] ** 2 / m["rms_error"] ** 2) <= 1e-12


def test_predict_derives_the_rate_and_checks_inputs(cli_fit):
    model = indicial.Model.load(str(cli_fit / "model.coef"))
    t = np.arange(200) * 0.01
    a = 0.5 - 0.3 * np.cos(2 * np.pi * t)
    p = indicial.predict(model, time_s=t, alpha_rad=a)
    assert p.predicted["Cm"].shape == (200,) and np.all(np.isfinite(p.predicted["Cm"]))
    with pytest.raises(indicial.InputError, match="^predict: the motion angle has 199 samples, time_s has 200"):
        indicial.predict(model, time_s=t, alpha_rad=a[:-1])
    with pytest.raises(indicial.InputError, match=r"^motion angle: \[5\] is NaN"):
        indicial.predict(model, time_s=t, alpha_rad=np.where(np.arange(200) == 5, np.nan, a))
    with pytest.raises(indicial.InputError, match="^measured: the model has no coefficient 'CL'"):
        indicial.predict(model, time_s=t, alpha_rad=a, measured={"CL": a})
    with pytest.raises(indicial.InputError, match="^airspeed_mps: must be > 0"):
        indicial.predict(model, time_s=t, alpha_rad=a, airspeed_mps=-3)


def test_score_from_s_equals_cli(case_dir, cli_fit, cli, tmp_path):
    """--score-from-s / score_from_s: the metrics cover the samples from that time on; the CLI's
    metrics file and Python agree; every sample is still predicted."""
    import json
    run_file = sorted(case_dir.glob("run_*.csv"))[-1]
    out = tmp_path / "pred.csv"
    cli("predict", cli_fit / "model.coef", run_file, "--out", out, "--score-from-s", "0.5")
    cli_metrics = json.load(open(tmp_path / "pred.metrics.json"))
    e = indicial.Experiment.from_toml(str(case_dir / "experiment.toml"))
    run = next(r for r in e.runs if r["name"].endswith(run_file.name))
    model = indicial.Model.load(str(cli_fit / "model.coef"))
    p = indicial.predict(model, time_s=run["time_s"], alpha_rad=run["motion_angle_rad"], q_radps=run["rate_radps"],
                         measured={"Cm": run["coefficient"]}, score_from_s=0.5)
    expected_count = int(np.sum(run["time_s"] >= 0.5))
    assert p.scored_samples == expected_count == cli_metrics["scored_samples"]
    assert cli_metrics["score_from_s"] == 0.5
    assert p.metrics["Cm"]["model"]["n_samples"] == expected_count
    assert p.predicted["Cm"].shape == run["time_s"].shape
    got, want = p.metrics["Cm"]["model"]["rms_error"], cli_metrics["coefficients"][0]["model"]["rms_error"]
    assert abs(got - want) <= 1e-12 * want
    with pytest.raises(indicial.InputError, match="^score_from_s: .* leaves 0 sample"):
        indicial.predict(model, time_s=run["time_s"], alpha_rad=run["motion_angle_rad"], score_from_s=1e9)


def test_a_jittered_time_grid_is_refused_unless_declared(cli_fit):
    """As the command line: time_grid="uniform" (the default) is checked, not assumed (a
    jittered log's derived rate was off by 64 % of its amplitude, without a word)."""
    model = indicial.Model.load(str(cli_fit / "model.coef"))
    t = np.arange(200) * 0.01
    t[10] += 0.004
    a = 0.5 - 0.3 * np.cos(2 * np.pi * t)
    with pytest.raises(indicial.InputError, match=r"^time_s: non-uniform time step: .* at time_s\[10\]"):
        indicial.predict(model, time_s=t, alpha_rad=a)
    p = indicial.predict(model, time_s=t, alpha_rad=a, time_grid="nonuniform")
    assert np.all(np.isfinite(p.predicted["Cm"]))
    with pytest.raises(indicial.InputError, match="^time_grid: expected 'uniform' or 'nonuniform'"):
        indicial.predict(model, time_s=t, alpha_rad=a, time_grid="jittered")


def test_predict_checks_a_cycle_and_warns_as_the_command_line(cli_fit):
    """A notebook user's trial (2026-11-30): periodic=True on a third of a cycle was predicted
    (the command line refuses it), and nothing was said of samples outside the envelope or of
    degrees passed as alpha_rad."""
    model = indicial.Model.load(str(cli_fit / "model.coef"))
    t = np.arange(200) * 0.005
    a = 0.5 - 0.3 * np.cos(2 * np.pi * t)  # one whole cycle of 200 samples
    with pytest.raises(indicial.InputError, match="^periodic: the motion is declared periodic .* not one whole cycle"):
        indicial.predict(model, time_s=t[:70], alpha_rad=a[:70], periodic=True)
    with pytest.warns(indicial.IndicialWarning, match="outside the model's envelope") as w:
        p = indicial.predict(model, time_s=t, alpha_rad=a + 0.6, periodic=True)
    assert p.warnings and str(w[0].message) == p.warnings[0]
    with pytest.warns(indicial.IndicialWarning, match="beyond 2 pi: it looks like degrees"):
        indicial.predict(model, time_s=t, alpha_rad=np.degrees(a))


def test_read_runs_is_predict_runs_cycle(cli_fit, cli, tmp_path):
    """read_runs: an experiment file's run as fit reads it, with no [static] needed; predicted, it
    is `indicial predict --experiment E --run 1` (the same samples, the same numbers)."""
    model_path = str(cli_fit / "model.coef")
    ph = np.sort(np.random.default_rng(5).uniform(0, 2 * np.pi, 60))
    with open(tmp_path / "a.csv", "w") as f:
        f.write("x,y\n" + "".join(f"{p!r},{np.degrees(0.5 - 0.3 * np.cos(p))!r}\n" for p in ph))
    with open(tmp_path / "c.csv", "w") as f:
        f.write("x,y\n" + "".join(f"{p!r},{-0.02 * np.sin(p)!r}\n" for p in ph[::2]))
    e = tmp_path / "held.toml"
    e.write_text('axis = "pitch"\ncoefficient = "Cm"\nreference_length_m = 0.5\nairspeed_mps = 20\n'
                 'runs = [{files = [{file = "a.csv", columns = {phase_rad = "x", alpha_deg = "y"}}, '
                 '{file = "c.csv", columns = {phase_rad = "x", Cm = "y"}}], frequency_hz = 0.5}]\n')
    r = indicial.read_runs(str(e))["Cm"][0]
    assert r["periodic"] and len(r["time_s"]) == 60 and r["frequency_hz"] == 0.5
    model = indicial.Model.load(model_path)
    p = indicial.predict(model, time_s=r["time_s"], alpha_rad=r["motion_angle_rad"],
                         q_radps=r["rate_radps"], periodic=True, airspeed_mps=r["airspeed_mps"],
                         measured={"Cm": r["coefficient"]})
    cli("predict", model_path, "--experiment", e, "--run", "1", "--out", tmp_path / "p.csv")
    rows = [line.split(",") for line in (tmp_path / "p.csv").read_text().splitlines()
            if line and not line.startswith("#") and not line.startswith("time_s")]
    np.testing.assert_allclose(p.predicted["Cm"], [float(x[2]) for x in rows], rtol=0, atol=1e-12)
    # run=r is the same call: its time, motion, periodic and airspeed, its Cm scored.
    q = indicial.predict(model, run=r)
    assert r["coefficient_name"] == "Cm" and q.metrics["Cm"]["model"] == p.metrics["Cm"]["model"]
    np.testing.assert_array_equal(q.predicted["Cm"], p.predicted["Cm"])
    with pytest.raises(TypeError, match="^predict: run= gives the motion.*not also periodic, alpha_rad"):
        indicial.predict(model, run=r, periodic=False, alpha_rad=r["motion_angle_rad"])
    with pytest.raises(indicial.InputError, match="run= is missing motion_angle_rad"):
        indicial.predict(model, run={"time_s": r["time_s"]})
    with pytest.raises(TypeError, match=r"time_s \(or run=\) is required"):
        indicial.predict(model, alpha_rad=r["motion_angle_rad"])
    # Another axis is refused (as --run refuses it); a coefficient the model lacks is warned of.
    with pytest.raises(indicial.InputError, match="^predict: run= is a roll run; the model is pitch"):
        indicial.predict(model, run=dict(r, axis="roll"))
    with pytest.warns(indicial.IndicialWarning, match="the run measures CL, which the model does not have"):
        q = indicial.predict(model, run=dict(r, coefficient_name="CL"))
    assert q.metrics == {}
