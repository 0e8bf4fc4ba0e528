"""indicial.diagnose equals `indicial diagnose`: Example 1's Model II data fitted with Model I's
constant b1 (the report's Table III modelling error): the missing b1(alpha) is named."""
import json

import pytest

import indicial


@pytest.fixture(scope="module")
def model1_config_on_model2_data(cli, tmp_path_factory):
    d = tmp_path_factory.mktemp("diag") / "m2"
    cli("simulate", "--case", "tailless-model-2", "--snr", "40", "--seed", "3", "--out", d)
    text = (d / "experiment.toml").read_text()
    lines = [l if not l.startswith("b1_knots_deg") else "b1_knots_deg = []" for l in text.splitlines()]
    (d / "experiment.toml").write_text("\n".join(lines) + "\n")
    return d / "experiment.toml"


def test_diagnose_equals_cli(model1_config_on_model2_data, cli, tmp_path):
    out = tmp_path / "d"
    cli("diagnose", model1_config_on_model2_data, "--out", out, "--no-plots", "--quiet", "--max-steps", "2",
        check=False)
    expected = json.loads((out / "diagnosis.json").read_text())
    d = indicial.diagnose(indicial.Experiment.from_toml(str(model1_config_on_model2_data)), max_steps=2, warn=False)
    assert d.verdict == expected["verdict"] == "b1_alpha"
    assert len(d.steps) == len(expected["steps"]) >= 1
    for s, c in zip(d.steps, expected["steps"]):
        assert s["effect"] == c["effect"] and s["detail"] == c["detail"]
        assert abs(s["statistic"] - c["statistic"]) <= 1e-12 * abs(c["statistic"])
        assert abs(s["fit_error_after"] - c["fit_error_after"]) <= 1e-12 * c["fit_error_after"]
    assert abs(d.final_fit_error - expected["final_fit_error"]) <= 1e-12 * expected["final_fit_error"]
    assert d.final_fit_error < d.initial_fit_error
    assert d.model.lags() == 1 and d.fit.termination == "converged"
    assert "b1_knots_deg" in d.experiment_toml()


def test_diagnose_min_in_sample_gain_is_checked(model1_config_on_model2_data):
    # The in-sample materiality floor (--min-in-sample-gain) is refused outside [0, 1) before
    # anything is fitted.
    e = indicial.Experiment.from_toml(str(model1_config_on_model2_data))
    with pytest.raises(indicial.InputError, match="min_in_sample_gain"):
        indicial.diagnose(e, min_in_sample_gain=1.0, warn=False)
