"""indicial.fit equals `indicial fit` on the same data (to 1e-12), from the experiment file and
from arrays; its options are checked with the command line's messages."""
import json
import re
import math
import tomllib

import numpy as np
import pytest

import indicial


def close(a, b, tol=1e-12):
    if a is None or b is None:
        return a is None and (b is None or not math.isfinite(b))
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


def assert_same_as_cli(result, fit_json):
    cli = json.loads(fit_json.read_text())
    assert [p["name"] for p in cli["parameters"]] == [p.name for p in result.parameters]
    for c, p in zip(cli["parameters"], result.parameters):
        assert close(c["value"], p.value), (p.name, c["value"], p.value)
        assert close(c["cr_bound"], p.cr_bound), (p.name, c["cr_bound"], p.cr_bound)
        assert close(c["cr_bound_colored"], p.cr_bound_colored), p.name
        assert c["identifiable"] == p.identifiable
    assert close(cli["fit_error"], result.fit_error)
    assert cli["termination"] == result.termination
    assert cli["iterations"] == result.iterations


def test_fit_from_toml_equals_cli(py_fit, cli_fit):
    assert py_fit.termination == "converged"
    assert_same_as_cli(py_fit, cli_fit / "fit.json")


def test_model_text_equals_cli_model_coef(py_fit, cli_fit):
    from_cli = indicial.Model.load(str(cli_fit / "model.coef"))
    # The provenance lines differ (command line, commit); everything else is the same bytes.
    strip = lambda t: "\n".join(l for l in t.splitlines() if not l.startswith("#") and not l.startswith("checksum"))
    assert strip(py_fit.model.text) == strip(from_cli.text)


def test_fit_from_arrays_equals_cli_on_the_written_files(tmp_path, cli):
    case = indicial.simulation_case("tailless-model-1", snr=40, seed=5)
    config = tomllib.loads(case.experiment_toml)
    runs = [indicial.Run(time_s=r.time_s, alpha_rad=r.motion_angle_rad, q_radps=r.rate_radps,
                         coefficient=r.measured["Cm"], name=r.name) for r in case.runs]
    e = indicial.Experiment(coefficient="Cm", reference_length_m=config["reference_length_m"],
                            airspeed_mps=config["airspeed_mps"], runs=runs,
                            static_polynomial=config["static"]["polynomial"],
                            rotary_polynomial=config["rotary"]["polynomial"], a_powers=[0, 1, 2],
                            a_knots_rad=np.radians(config["model"]["a_knots_deg"]), b1_powers=[0])
    r = indicial.fit(e, warn=False)
    assert r.termination == "converged"
    e.write_files(str(tmp_path / "exp"))
    cli("fit", tmp_path / "exp" / "experiment.toml", "--out", tmp_path / "out", "--no-plots", "--quiet")
    assert_same_as_cli(r, tmp_path / "out" / "fit.json")


def test_fit_from_arrays_beside_a_file_of_its_name(tmp_path, monkeypatch):
    """An Experiment from arrays is named "experiment", its runs "run 1", ...: names, not files.
    A file called "experiment" in the working directory made fit hash the runs as files and
    raise "run 1: cannot be read"; the fit runs, and its provenance lists no inputs."""
    case = indicial.simulation_case("tailless-model-1", snr=40, seed=5)
    config = tomllib.loads(case.experiment_toml)
    runs = [indicial.Run(time_s=r.time_s, alpha_rad=r.motion_angle_rad, q_radps=r.rate_radps,
                         coefficient=r.measured["Cm"]) for r in case.runs]
    e = indicial.Experiment(coefficient="Cm", reference_length_m=config["reference_length_m"],
                            airspeed_mps=config["airspeed_mps"], runs=runs,
                            static_polynomial=config["static"]["polynomial"], b1_powers=[0])
    monkeypatch.chdir(tmp_path)
    (tmp_path / "experiment").write_text("not an experiment\n")
    r = indicial.fit(e, warn=False)
    assert r.termination == "converged"
    assert "sha256" not in r.model.text


def test_result_objects(py_fit):
    p = py_fit.parameter("b1_0")
    assert p.value > 0 and 0 < p.cr_bound < p.value and p.cr_bound_colored > 0
    assert py_fit.fit_error > 0 and py_fit.message
    assert py_fit.covariance.shape == (len(py_fit.parameters),) * 2
    x = np.linspace(0.1, 0.9, 5)
    value, sigma = py_fit.band("a", x)
    assert np.allclose(value, py_fit.model.a(x), rtol=1e-12, atol=1e-12) and np.all(sigma > 0)
    run = py_fit.runs[0]
    assert np.allclose(run["residual"], run["measured"] - run["model"], atol=1e-12)
    assert json.loads(py_fit.fit_json())["termination"] == "converged"


# A range (FitOptions::IsValid, fitter/src/estimate/fit_options.cpp): its own one-line message,
# the command line's word for word (tests/test_fit_cli.cpp), before anything is fitted.
@pytest.mark.parametrize("options, message", [
    (dict(f_to_enter=2.0, f_to_remove=3.0),
     "f_to_remove (--f-to-remove): must be in (0, f_to_enter = 2] (F to enter >= F to remove > 0), found 3"),
    (dict(f_to_enter=0.0), "f_to_enter (--f-to-enter): must be > 0 (a partial F), found 0"),
    (dict(max_iterations=-1), "max_iterations (--max-iterations): must be >= 0 (0: the start evaluated, no step), found -1"),
    (dict(fallback_r_squared=1.5), "fallback_r_squared (--fallback-r-squared): must be in [0, 1], found 1.5"),
    (dict(state_derivative="spline"), "state_derivative: expected one of 'modulating', 'smoothed', found 'spline'"),
    (dict(start_values={"b1_0": float("nan")}), "start_values (--start-value): must be finite numbers, found b1_0=nan"),
])
def test_bad_options_are_input_errors(case_dir, options, message):
    e = indicial.Experiment.from_toml(str(case_dir / "experiment.toml"))
    with pytest.raises(indicial.InputError, match="^" + re.escape(message) + "$"):
        indicial.fit(e, **options)


def test_unknown_start_value_is_the_fitters_message(case_dir):
    e = indicial.Experiment.from_toml(str(case_dir / "experiment.toml"))
    with pytest.raises(indicial.InputError, match="zz9"):
        indicial.fit(e, start_values={"zz9": 1.0})


def test_stall_experiment_from_arrays_equals_its_toml(tmp_path, cli, stall_experiment_kwargs):
    """A static table, the separation and vortex families and stall_known from arrays: the same
    fit (parameters and s(v) to 1e-12) as the experiment file write_files writes, read by
    from_toml and by `indicial fit`."""
    e = indicial.Experiment(**stall_experiment_kwargs)
    r = indicial.fit(e, warn=False)
    assert r.termination == "converged"
    assert [p.name for p in r.parameters] == ["a0", "b1_0", "T1", "k0", "k1", "k2", "CN1", "Tv", "cv", "xv"]
    assert json.loads(r.fit_json())["held_parameters"] == {"T2": 1.5, "Tvl": 7.0}
    e.write_files(str(tmp_path / "exp"))
    text = (tmp_path / "exp" / "experiment.toml").read_text()
    assert text == e.toml_text()
    model = tomllib.loads(text)["model"]
    assert tomllib.loads(text)["static"] == {"table": "static_table.csv"}
    assert model["stall"] == "separation_and_vortex" and model["stall_known"] == {"T2": 1.5, "Tvl": 7.0}
    assert model["stall_T1_start"] == 2.5 and "stall_T2_start" not in model and "stall_polar" not in model
    back = indicial.fit(indicial.Experiment.from_toml(str(tmp_path / "exp" / "experiment.toml")), warn=False)
    assert [p.name for p in back.parameters] == [p.name for p in r.parameters]
    for p, q in zip(r.parameters, back.parameters):
        assert close(p.value, q.value) and close(p.cr_bound, q.cr_bound), (p.name, p.value, q.value)
    assert close(r.fit_error, back.fit_error)
    cli("fit", tmp_path / "exp" / "experiment.toml", "--out", tmp_path / "out", "--no-plots", "--quiet")
    assert_same_as_cli(r, tmp_path / "out" / "fit.json")


def test_stall_prior_keyword_is_the_clis_flag(tmp_path, cli, stall_experiment_kwargs):
    """stall_prior="none" (maximum likelihood alone) is `indicial fit --stall-prior none`: the
    same fit, recorded in fit.json's options, and not the default's (the a priori values move
    the stall estimates); an unknown word is refused with the choices."""
    e = indicial.Experiment(**stall_experiment_kwargs)
    default = indicial.fit(e, warn=False)
    alone = indicial.fit(e, stall_prior="none", warn=False)
    assert json.loads(default.fit_json())["options"]["stall_prior"] == "beddoes_leishman"
    assert json.loads(alone.fit_json())["options"]["stall_prior"] == "none"
    assert any(not close(p.value, q.value) for p, q in zip(default.parameters, alone.parameters))
    e.write_files(str(tmp_path / "exp"))
    cli("fit", tmp_path / "exp" / "experiment.toml", "--out", tmp_path / "out", "--no-plots", "--quiet",
        "--stall-prior", "none")
    assert_same_as_cli(alone, tmp_path / "out" / "fit.json")
    with pytest.raises(indicial.InputError, match="stall_prior"):
        indicial.fit(e, stall_prior="flat")


def test_stall_polar_of_its_own_from_arrays_equals_its_toml(tmp_path, stall_experiment_kwargs):
    """A lift polar of its own (written as stall_polar.csv), the f0 correction, the attached
    range and a start value written and read back: the same fit."""
    kw = dict(stall_experiment_kwargs)
    kw.update(stall="separation", stall_known={"k2": 0.0}, stall_polar_alpha_rad=kw["static_table_x_rad"],
              stall_polar_lift=kw["static_table_value"] * 1.01, stall_attached_max_deg=7.0,
              stall_f0_correction_powers=[0], stall_T2_start=1.2)
    e = indicial.Experiment(**kw)
    model = tomllib.loads(e.toml_text())["model"]
    assert model["stall_polar"] == "stall_polar.csv" and model["stall_f0_correction_degree"] == 0
    assert model["stall_attached_max_deg"] == 7 and model["stall_T2_start"] == 1.2
    r = indicial.fit(e, warn=False)
    assert r.termination == "converged" and "f0c_0" in [p.name for p in r.parameters]
    e.write_files(str(tmp_path / "exp"))
    back = indicial.fit(indicial.Experiment.from_toml(str(tmp_path / "exp" / "experiment.toml")), warn=False)
    assert [(p.name, p.value) for p in r.parameters] == [(p.name, p.value) for p in back.parameters]
    assert r.fit_error == back.fit_error


def test_delay_from_arrays_reads_back_the_same(tmp_path, stall_experiment_kwargs):
    """delay = "estimated" and delay_start_s: written, read back by the experiment file's reader,
    and written again to the same text (the configuration is the same)."""
    e = indicial.Experiment(**stall_experiment_kwargs, delay="estimated", delay_start_s=0.002)
    model = tomllib.loads(e.toml_text())["model"]
    assert model["delay"] == "estimated" and model["delay_start_s"] == 0.002
    e.write_files(str(tmp_path / "exp"))
    assert indicial.Experiment.from_toml(str(tmp_path / "exp" / "experiment.toml")).toml_text() == e.toml_text()
