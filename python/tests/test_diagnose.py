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
        assert s["rule"] == c["rule"]  # what decided, with its held-out evidence as diagnosis.json's
        assert list(s["held_out_rms_after"]) == pytest.approx(c.get("held_out_rms_after", []), rel=1e-12)
    assert abs(d.final_fit_error - expected["final_fit_error"]) <= 1e-12 * expected["final_fit_error"]
    assert d.final_fit_error < d.initial_fit_error
    assert d.model.lags() == 1 and d.fit.termination == "converged"
    assert d.unconverged_models == expected["unconverged_models"] == []
    assert "b1_knots_deg" in d.experiment_toml()


def test_diagnose_rule_options_reach_diagnosis_json(model1_config_on_model2_data, cli, tmp_path):
    # rule, max_folds, min_gain, min_in_sample_gain and threads, each away from its default, as
    # the command line's options: the same diagnosis.json keys, and the same steps (the command
    # line on 2 threads, Python on 1: the thread count changes no result).
    options = dict(rule="cv", max_folds=2, min_gain=0.2, min_in_sample_gain=0.05)
    out = tmp_path / "d"
    cli("diagnose", model1_config_on_model2_data, "--out", out, "--no-plots", "--quiet", "--max-steps", "1",
        "--rule", "cv", "--max-folds", "2", "--min-gain", "0.2", "--min-in-sample-gain", "0.05", "--threads", "2",
        check=False)
    expected = json.loads((out / "diagnosis.json").read_text())
    e = indicial.Experiment.from_toml(str(model1_config_on_model2_data))
    d = indicial.diagnose(e, max_steps=1, threads=1, warn=False, **options)
    j = json.loads(d.diagnosis_json())
    assert j["rule"] == expected["rule"] == "leave_one_run_out"
    assert j["cv_folds"] == expected["cv_folds"] == 2  # three runs dealt into two folds
    assert j["cv_min_gain"] == expected["cv_min_gain"] == 0.2
    assert j["cv_min_in_sample_gain"] == expected["cv_min_in_sample_gain"] == 0.05
    assert (j["threads"], expected["threads"]) == (1, 2)
    assert [s["effect"] for s in j["steps"]] == [s["effect"] for s in expected["steps"]]
    assert abs(j["final_fit_error"] - expected["final_fit_error"]) <= 1e-12 * expected["final_fit_error"]
    lr = json.loads(indicial.diagnose(e, max_steps=1, rule="lr", warn=False).diagnosis_json())
    assert lr["rule"].startswith("lr_") and "cv_folds" not in lr and lr["threads"] == 2
    # cv_min_runs (--cv-min-runs): three runs are too few when four are required.
    few = json.loads(indicial.diagnose(e, max_steps=0, cv_min_runs=4, warn=False).diagnosis_json())
    assert few["rule"].startswith("lr_") and "cv_folds" not in few


# One bad option each (DiagnoseOptions::IsValid, fitter/src/diagnose/diagnose_options.cpp, and
# for a fit option FitOptions::IsValid, fitter/src/estimate/fit_options.cpp): a ValueError (indicial.InputError) with the option's one-line message, before anything is fitted.
@pytest.mark.parametrize("option, message", [
    (dict(alpha=0.0), r"^alpha \(--alpha\): must be in \(0, 1\).*found 0$"),
    (dict(alpha=1.5), r"^alpha \(--alpha\): must be in \(0, 1\).*found 1.5$"),
    (dict(max_steps=-1), r"^max_steps \(--max-steps\): must be >= 0.*found -1$"),
    (dict(knot_spacing_deg=0.0), r"^knot_spacing_deg \(--knot-spacing-deg\): must be positive and finite.*found 0$"),
    (dict(knot_margin_fraction=0.5), r"^knot_margin_fraction: must be in \[0, 0.5\).*found 0.5$"),
    (dict(max_scan_knots=0), r"^max_scan_knots: must be >= 1.*found 0$"),
    (dict(max_family_terms=0), r"^max_family_terms \(--max-family-terms\): must be >= 1.*found 0$"),
    (dict(indistinguishable_bic=-1.0), r"^indistinguishable_bic: must be >= 0.*found -1$"),
    (dict(min_in_sample_gain=1.0), r"^cv_min_in_sample_gain \(--min-in-sample-gain\): must be in \[0, 1\).*found 1$"),
    (dict(min_gain=1.0), r"^cv_min_gain \(--min-gain\): must be in \[0, 1\).*found 1$"),
    (dict(min_gain=-0.5), r"^cv_min_gain \(--min-gain\): must be in \[0, 1\).*found -0.5$"),
    (dict(max_folds=1), r"^cv_max_folds \(--max-folds\): must be >= 2.*found 1$"),
    (dict(cv_min_runs=1), r"^cv_min_runs \(--cv-min-runs\): must be >= 2.*found 1$"),
    # A fit option: its field (the keyword) alone, as diagnose has no --f-to-remove.
    (dict(f_to_remove=5.0), r"^f_to_remove: must be in \(0, f_to_enter = 4\].*found 5$"),
    (dict(max_iterations=-1), r"^max_iterations: must be >= 0.*found -1$"),
    (dict(start_values={"b1_0": float("nan")}), r"^start_values: must be finite numbers, found b1_0=nan$"),
    (dict(threads=0), r"^threads \(--threads\): must be >= 1.*found 0$"),
    (dict(rule="loo"), r"^rule: expected one of 'auto', 'cv', 'lr', found 'loo'$"),
    (dict(cv_unit="entry"), r"^cv_unit: expected one of 'group', 'run', found 'entry'$"),
])
def test_diagnose_bad_option_is_refused(model1_config_on_model2_data, option, message):
    e = indicial.Experiment.from_toml(str(model1_config_on_model2_data))
    with pytest.raises(ValueError, match=message) as refused:
        indicial.diagnose(e, warn=False, **option)
    assert isinstance(refused.value, indicial.InputError)


def test_cv_unit_group_leaves_whole_groups_out(model1_config_on_model2_data, cli, tmp_path):
    """cv_unit="group" (--cv-unit group): the runs' groups are the folds (two groups of the three
    runs: two folds), said in diagnosis.json as the command line says it; without groups it is
    an error naming the run, before anything is fitted."""
    text = model1_config_on_model2_data.read_text()
    runs = [l for l in text.splitlines() if l.startswith("runs = ")][0]
    names = json.loads(runs[len("runs = "):])
    assert len(names) == 3
    entries = ", ".join(f'{{file = "{n}", group = "{g}"}}' for n, g in zip(names, ("entry A", "entry B", "entry A")))
    path = model1_config_on_model2_data.parent / "grouped.toml"
    path.write_text(text.replace(runs, f"runs = [{entries}]"))
    grouped = indicial.Experiment.from_toml(str(path))
    assert [r["group"] for r in grouped.runs] == ["entry A", "entry B", "entry A"]
    j = json.loads(indicial.diagnose(grouped, max_steps=1, cv_unit="group", warn=False).diagnosis_json())
    assert j["rule"] == "leave_one_run_out" and j["cv_unit"] == "group"
    assert j["cv_groups"] == ["entry A", "entry B"] and j["cv_folds"] == 2
    assert "whole groups left out: 2 groups" in j["rule_reason"]
    by_run = json.loads(indicial.diagnose(grouped, max_steps=0, warn=False).diagnosis_json())
    assert by_run["cv_unit"] == "run" and by_run["cv_folds"] == 3 and "cv_groups" not in by_run
    cli("diagnose", path, "--out", tmp_path / "d", "--no-plots", "--quiet",
        "--max-steps", "1", "--cv-unit", "group", check=False)
    expected = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    assert expected["cv_groups"] == j["cv_groups"] and expected["cv_folds"] == 2
    plain = indicial.Experiment.from_toml(str(model1_config_on_model2_data))
    with pytest.raises(indicial.InputError, match="--cv-unit group: run '.*' has no 'group'"):
        indicial.diagnose(plain, max_steps=1, cv_unit="group", warn=False)
