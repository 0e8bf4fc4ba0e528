"""indicial.Experiment: from the experiment file (the command line's reader and messages) and
from arrays (the same checks a run file gets), and bad input as exceptions, never a crash."""
import json
import math

import numpy as np
import pytest

import indicial


def sine_run(n=400, dt=0.01, **kw):
    t = np.arange(n) * dt
    a = 0.3 - 0.2 * np.cos(2 * np.pi * 0.5 * t)
    cm = -0.1 * a + 0.01 * np.sin(3 * t)
    args = dict(time_s=t, alpha_rad=a, coefficient=cm)
    args.update(kw)
    return args


def experiment(**run_kw):
    return indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=30.0,
                               runs=[indicial.Run(**sine_run(**run_kw))])


def test_from_toml_reads_runs(case_dir):
    e = indicial.Experiment.from_toml(str(case_dir / "experiment.toml"))
    assert e.coefficient == "Cm" and e.axis == "pitch" and len(e.runs) >= 2
    r = e.runs[0]
    assert r["time_s"].shape == r["motion_angle_rad"].shape == r["coefficient"].shape


def test_runs_feed_run_from_dict_and_rebuild_the_experiment(case_dir):
    """Experiment.runs -> Run.from_dict -> Experiment: the same arrays (some runs of an
    experiment refitted in a notebook), the axis-neutral motion taken as the experiment's."""
    e = indicial.Experiment.from_toml(str(case_dir / "experiment.toml"))
    runs = e.runs
    assert all(r["coefficient_name"] == "Cm" for r in runs)
    again = indicial.Experiment(coefficient="Cm", reference_length_m=e.reference_length_m,
                                airspeed_mps=e.airspeed_mps, runs=[indicial.Run.from_dict(r) for r in runs[:2]])
    for a, b in zip(again.runs, runs[:2]):
        for key in ("time_s", "motion_angle_rad", "rate_radps", "coefficient"):
            np.testing.assert_array_equal(a[key], b[key])
        assert a["periodic"] == b["periodic"] and a["time_grid"] == b["time_grid"]
    with pytest.raises(indicial.InputError, match="^Run.from_dict: missing motion_angle_rad, coefficient"):
        indicial.Run.from_dict({"time_s": runs[0]["time_s"]})
    # A run of another coefficient or axis is refused, not fitted as this one's.
    with pytest.raises(indicial.InputError, match=r"^runs\[0\]: Run.from_dict of a Cm run; the experiment's coefficient is CL"):
        indicial.Experiment(coefficient="CL", reference_length_m=1.0, airspeed_mps=30.0,
                            runs=[indicial.Run.from_dict(runs[0])])
    with pytest.raises(indicial.InputError, match=r"^runs\[0\]: Run.from_dict of a pitch run; the experiment's axis is roll"):
        indicial.Experiment(coefficient="Cm", reference_length_m=1.0, airspeed_mps=30.0, axis="roll",
                            runs=[indicial.Run.from_dict(runs[0])])


def test_from_toml_error_is_the_cli_message(tmp_path, cli):
    bad = tmp_path / "bad.toml"
    bad.write_text('coefficient = "Cm"\nreference_length_m = 1\nairspeed_mps = 10\nruns = ["nope.csv"]\nbogus = 1\n')
    with pytest.raises(indicial.InputError) as py_err:
        indicial.Experiment.from_toml(str(bad))
    out = cli("fit", bad, "--out", tmp_path / "o", check=False)
    assert out.returncode == 1
    assert str(py_err.value) in out.stderr  # "indicial: error: <the same line>"


def test_from_arrays_derives_the_rate():
    e = experiment()
    r = e.runs[0]
    expected = 0.2 * 2 * np.pi * 0.5 * np.sin(2 * np.pi * 0.5 * r["time_s"])
    assert np.max(np.abs(r["rate_radps"] - expected)) < 5e-4  # of 0.63 rad/s; the ends are one-sided


def test_non_contiguous_and_integer_arrays_are_converted():
    args = sine_run()
    t2 = np.repeat(args["time_s"], 2)[::2]  # a strided view
    assert not t2.flags.c_contiguous
    e = indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=30,
                            runs=[indicial.Run(time_s=t2, alpha_rad=args["alpha_rad"].astype(np.float32),
                                               coefficient=args["coefficient"])])
    assert np.array_equal(e.runs[0]["time_s"], args["time_s"])


@pytest.mark.parametrize("change, exc, message", [
    (dict(coefficient=np.zeros(399)), indicial.InputError, "run 1: the coefficient has 399 samples, time_s has 400"),
    (dict(time_s=np.array(["a"] * 400)), TypeError, "time_s: expected an array of real numbers"),
    (dict(alpha_rad=np.full(400, np.nan)), indicial.InputError, r"run 1: motion angle\[0\] is NaN"),
    (dict(time_s=np.zeros(400)), indicial.InputError, "run 1: time_s is not strictly increasing"),
    (dict(time_s=np.arange(400) * 0.01 + np.r_[0, 0.003, np.zeros(398)]), indicial.InputError,
     "run 1: non-uniform time step"),
    (dict(n=5), indicial.InputError, "run 1: has 5 samples; a run needs at least 11"),
    (dict(alpha_rad=np.zeros((400, 2))), indicial.InputError, "motion angle: expected a 1-D array"),
    (dict(time_s=None), TypeError, "time_s: expected an array of numbers, got None"),
    # a third of a cycle declared periodic: the file reader refuses it, so Run(...) does (its
    # write_files would write a run `indicial fit` refuses)
    (dict(n=130, periodic=True), indicial.InputError, "run 1: is declared periodic .* not one whole cycle"),
])
def test_bad_arrays_raise(change, exc, message):
    n = change.pop("n", 400)
    args = sine_run(n=n)
    args.update(change)
    with pytest.raises(exc, match="^" + message):
        indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=30, runs=[indicial.Run(**args)])


def test_bad_configuration_raises():
    run = indicial.Run(**sine_run())
    with pytest.raises(indicial.InputError, match=r"^'a_knots_rad': knot 114.592 deg is outside the data's alpha range"):
        indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=30, runs=[run], a_knots_rad=[2.0])
    with pytest.raises(indicial.InputError, match="^airspeed_mps: must be a finite number > 0"):
        indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=-1, runs=[run])
    with pytest.raises(indicial.InputError, match="^structure: expected one of 'fixed', 'stepwise'"):
        indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=3, runs=[run], structure="x")
    with pytest.raises(indicial.InputError, match="phi_rad: the model's axis is pitch"):
        indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=3,
                            runs=[indicial.Run(time_s=np.arange(20.), phi_rad=np.arange(20.), coefficient=np.zeros(20))])
    still = sine_run()
    still["alpha_rad"] = np.full(400, 0.1)
    with pytest.raises(indicial.InputError, match="no run moves"):
        indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=3, runs=[indicial.Run(**still)])


def test_write_files_refuses_a_non_empty_directory(tmp_path):
    e = experiment()
    e.write_files(str(tmp_path / "x"))
    assert (tmp_path / "x" / "experiment.toml").is_file() and (tmp_path / "x" / "run1.csv").is_file()
    with pytest.raises(indicial.InputError):
        e.write_files(str(tmp_path / "x"))
    back = indicial.Experiment.from_toml(str(tmp_path / "x" / "experiment.toml"))
    assert np.array_equal(back.runs[0]["motion_angle_rad"], e.runs[0]["motion_angle_rad"])
    assert np.array_equal(back.runs[0]["rate_radps"], e.runs[0]["rate_radps"])


def _bad_table():
    x = np.arange(-12, 37) * np.pi / 180
    x[3] = x[2]
    return x


# One bad keyword each: InputError naming the keyword, with the experiment file's message
# (experiment_checks.hpp: the same checks and words as the TOML reader, the keyword for the
# file's 'model.' key and line).
@pytest.mark.parametrize("change, message", [
    (dict(static_table_x_rad=_bad_table()),
     r"static_table_x_rad\[3\]: the angle column is not strictly increasing \(-0.17453292519943295 after -0.17453292519943295\)"),
    (dict(static_table_x_rad=[0.0], static_table_value=[0.0]), r"static_table_x_rad\[0\]: a static table needs at least 2 rows"),
    (dict(static_table_x_rad=np.linspace(-0.3, 0.7, 70), static_table_value=np.zeros(70)),
     "'static_table_x_rad' needs 70 rows; the runtime \\(indicial::DefaultCapacity\\) holds at most 64"),
    (dict(static_table_value=None), "static_table_value: required with static_table_x_rad"),
    (dict(static_table_value=np.full(49, np.nan)), r"static_table_value\[0\] is NaN"),
    (dict(static_table_value=np.zeros(48)), "static_table_x_rad: the table has 49 angles and 48 values"),
    (dict(static_polynomial=[0.0, 6.0]), "static_table_x_rad: give static_polynomial or static_table_x_rad"),
    (dict(static_table_x_rad=np.linspace(0.1, 0.3, 5), static_table_value=np.zeros(5)),
     r"the static table 'static_table_x_rad' covers alpha \[5.72958, 17.1887\] deg but the runs reach \[4, 24\] deg"),
    (dict(delay="later"), "delay: expected one of 'none', 'estimated', found 'later'"),
    (dict(delay_start_s=0.01), "'delay_start_s' is used only with delay = \"estimated\""),
    (dict(delay="estimated", delay_start_s=2.0), r"'delay_start_s' must be in \[0, 1\] s"),
    (dict(stall="deep"), "stall: expected one of 'none', 'separation', 'separation_and_vortex', found 'deep'"),
    (dict(stall=None, stall_known=None),
     "'stall_T1_start' is used only with stall = \"separation\" or \"separation_and_vortex\""),
    (dict(stall_T1_start=0.0), "'stall_T1_start' must be > 0"),
    (dict(stall_T2_start=-1.0), "'stall_T2_start' must be >= 0"),
    (dict(stall_Tv_start=float("nan")), "'stall_Tv_start' must be > 0"),
    (dict(stall_attached_max_deg=-8.0), "'stall_attached_max_deg' must be > 0"),
    (dict(stall_known={"tau1": 5.0}), "'stall_known' names 'tau1', not a dynamic-stall parameter"),
    (dict(stall="separation", stall_known={"Tv": 5.0}),
     "'stall_known\\[\"Tv\"\\]' is a vortex parameter: it needs stall = \"separation_and_vortex\""),
    (dict(stall_known={"T2": -0.5}), "'stall_known\\[\"T2\"\\]' must be >= 0"),
    (dict(stall_known={"CN1": float("inf")}), "'stall_known\\[\"CN1\"\\]' must be finite"),
    (dict(stall_known={"T1": 3.0}),
     "'stall_known\\[\"T1\"\\]' holds T1 at a known value, and 'stall_T1_start' gives it a start value: drop one"),
    (dict(static_table_x_rad=None, static_table_value=None, static_polynomial=[0.0, 6.0]),
     "stall: the dynamic-stall families need the static lift polar: give stall_polar_alpha_rad and stall_polar_lift"),
    (dict(stall_polar_column="Cnormal"), "stall: the dynamic-stall families need the static lift polar"),
    (dict(stall_polar_lift=np.zeros(5)), "stall_polar_alpha_rad: required with stall_polar_lift"),
    (dict(stall_polar_alpha_rad=[0.1, 0.1, 0.2], stall_polar_lift=[0, 1, 2]),
     r"stall_polar_alpha_rad\[1\]: the angle column is not strictly increasing \(0.1 after 0.1\)"),
    (dict(stall_f0_correction_knots_rad=[1.0]),
     r"'stall_f0_correction_knots_rad': knot 57.2958 deg is outside the data's alpha range \[4, 24\] deg"),
    (dict(stall_f0_correction_knots_rad=[0.3, 0.2]), "'stall_f0_correction_knots_rad' must be strictly increasing"),
    (dict(static_table_lift=np.zeros(49)), "static_table_lift: the static table's lift column is for a pitch "
     "experiment of another coefficient than CL \\(this one: CL, pitch\\)"),
    (dict(stall_f0_correction_powers=[1, 0]), "stall_f0_correction_powers: powers must be distinct, ascending"),
])
def test_bad_stall_table_and_delay_keywords_raise(stall_experiment_kwargs, change, message):
    kw = dict(stall_experiment_kwargs)
    kw.update(change)
    with pytest.raises(indicial.InputError, match="^" + message):
        indicial.Experiment(**kw)


_NINE_KNOTS = list(np.linspace(0.15, 0.45, 9))  # inside sine_run's alpha range (0.1..0.5 rad)


# The runtime's capacity (indicial::DefaultCapacity: 8 powers, 8 knots, 2 lags) is the experiment
# file's own rule (experiment_checks.hpp check_runtime_capacity): the same words, the keyword for
# the file's key.
@pytest.mark.parametrize("change, message", [
    (dict(a_knots_rad=_NINE_KNOTS), "'a_knots_rad' needs 9 knots"),
    (dict(b1_powers=list(range(9))), r"'b1_powers' needs 9 powers \(x\^0..x\^n\)"),
    (dict(static_polynomial=[0.0] * 9), "'static_polynomial' needs 9 coefficients"),
    (dict(rotary_polynomial=[0.0] * 9), "'rotary_polynomial' needs 9 coefficients"),
    (dict(lags=3), "'lags' needs 3 lags"),
])
def test_over_capacity_is_refused_as_the_file_does(change, message):
    with pytest.raises(indicial.InputError, match="^" + message + "; the runtime \\(indicial::DefaultCapacity\\) "
                       "holds at most [28]$"):
        indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=30.0,
                            runs=[indicial.Run(**sine_run())], **change)


def test_an_over_capacity_candidate_pool_is_the_files_warning(tmp_path):
    """A stepwise pool (a, b1) or an estimated rotary pool may exceed the capacity: warned about,
    with the file's words; the same experiment read from its file warns at the key's line."""
    pools = [(dict(structure="stepwise", a_knots_rad=_NINE_KNOTS), "a_knots_rad", "model.a_knots_deg"),
             (dict(rotary_estimate=True, rotary_knots_rad=_NINE_KNOTS), "rotary_knots_rad", "rotary.knots_deg")]
    for change, keyword, key in pools:
        e = indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=30.0,
                                runs=[indicial.Run(**sine_run())], **change)
        text = ("needs 9 knots; the runtime (indicial::DefaultCapacity) holds at most 8: a candidate pool may "
                "exceed it, the selected model must not")
        assert f"'{keyword}' {text}" in e.warnings
        e.write_files(str(tmp_path / keyword))
        toml = tmp_path / keyword / "experiment.toml"
        line = next(i for i, s in enumerate(toml.read_text().splitlines(), 1) if s.startswith(key.split(".")[1] + " ="))
        assert f"{toml}:{line}: '{key}' {text}" in indicial.Experiment.from_toml(str(toml)).warnings


def test_stall_start_keywords_are_the_one_table():
    """Experiment's stall start keywords are the file's start keys, the one table
    (experiment_checks.hpp stall_starts()) the readers, the writer and `indicial init` use."""
    import inspect
    keys = indicial._indicial._stall_start_keys()
    assert keys == ["stall_T1_start", "stall_T2_start", "stall_CN1_start", "stall_Tv_start", "stall_Tvl_start",
                    "stall_T1r_start", "stall_dxr_start", "stall_dxl_start"]
    signature = [k for k in inspect.signature(indicial.Experiment.__init__).parameters
                 if k.startswith("stall_") and k.endswith("_start")]
    assert sorted(signature) == sorted(keys)


def test_each_stall_start_keyword_reaches_the_experiment_file(stall_experiment_kwargs):
    for key in indicial._indicial._stall_start_keys():
        kw = dict(stall_experiment_kwargs, stall_known=None)
        value = 0.0625 if key in ("stall_dxr_start", "stall_dxl_start") else 2.25  # rad, at most 20 deg
        kw[key] = value
        needs = {"stall_T1r_start": "stall_reattachment", "stall_dxr_start": "stall_hysteresis",
                 "stall_dxl_start": "stall_lag_limit"}
        if key in needs:  # T1r's, dxr's and dxl's starts need their parameter, as in the file
            with pytest.raises(indicial.InputError, match=needs[key] + ' = "estimated"'):
                indicial.Experiment(**kw)
            kw[needs[key]] = "estimated"
            assert needs[key] + ' = "estimated"\n' in indicial.Experiment(**kw).toml_text()
        assert f"{key} = {value:g}\n" in indicial.Experiment(**kw).toml_text()
    # dxr's start outside (0, 20 deg] is refused with the key named.
    kw = dict(stall_experiment_kwargs, stall_known=None, stall_hysteresis="estimated", stall_dxr_start=0.5)
    with pytest.raises(indicial.InputError, match="stall_dxr_start"):
        indicial.Experiment(**kw)


def test_stall_lag_limit_keyword_needs_the_delay_form(stall_experiment_kwargs):
    kw = dict(stall_experiment_kwargs, stall_lag_limit="estimated")
    assert 'stall_lag_limit = "estimated"\n' in indicial.Experiment(**kw).toml_text()
    kw["stall_forcing_lag"] = "first_order"
    with pytest.raises(indicial.InputError, match="stall_lag_limit"):
        indicial.Experiment(**kw)


def test_stall_forcing_lag_keyword_reaches_the_experiment_file(stall_experiment_kwargs):
    kw = dict(stall_experiment_kwargs, stall_forcing_lag="first_order")
    assert 'stall_forcing_lag = "first_order"\n' in indicial.Experiment(**kw).toml_text()
    assert "stall_forcing_lag" not in indicial.Experiment(**stall_experiment_kwargs).toml_text()
    with pytest.raises(indicial.InputError, match="stall_forcing_lag"):
        indicial.Experiment(**dict(stall_experiment_kwargs, stall_forcing_lag="filter"))


def test_stall_keywords_fill_what_the_file_does(stall_experiment_kwargs):
    e = indicial.Experiment(**stall_experiment_kwargs)
    assert 'stall = "separation_and_vortex"' in e.toml_text() and "stall_known = { T2 = 1.5, Tvl = 7 }" in e.toml_text()


@pytest.mark.parametrize("knots_rad, message", [
    ([1.0], "'{key}': knot 57.2958 deg is outside the data's alpha range [4, 24] deg"),
    ([0.3, 0.2], "'{key}' must be strictly increasing"),
])
def test_f0_correction_knots_get_the_files_check(tmp_path, stall_experiment_kwargs, knots_rad, message):
    """A bad stall_f0_correction_knots_rad from arrays and the same knots in the experiment file:
    one check (experiment_checks.hpp), one message, each naming its own key (the file also its line)."""
    with pytest.raises(indicial.InputError) as from_arrays:
        indicial.Experiment(**stall_experiment_kwargs, stall_f0_correction_knots_rad=knots_rad)
    assert str(from_arrays.value) == message.format(key="stall_f0_correction_knots_rad")
    good = indicial.Experiment(**stall_experiment_kwargs, stall_f0_correction_knots_rad=[0.2, 0.3])
    good.write_files(str(tmp_path / "exp"))
    toml = tmp_path / "exp" / "experiment.toml"
    lines = toml.read_text().splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("stall_f0_correction_knots_deg = "))
    lines[at] = "stall_f0_correction_knots_deg = [" + ", ".join(repr(math.degrees(k)) for k in knots_rad) + "]"
    toml.write_text("\n".join(lines) + "\n")
    with pytest.raises(indicial.InputError) as from_file:
        indicial.Experiment.from_toml(str(toml))
    assert str(from_file.value) == f"{toml}:{at + 1}: " + message.format(key="model.stall_f0_correction_knots_deg")


def test_stall_is_refused_outside_pitch(stall_experiment_kwargs):
    """The dynamic-stall families act on the angle of attack: a roll or yaw experiment with stall
    is refused (the file's check and message; the file names its line: test_experiment_checks)."""
    t = np.arange(200) * 0.01
    for axis, angle in (("roll", "phi_rad"), ("yaw", "psi_rad")):
        run = indicial.Run(time_s=t, coefficient=0.01 * np.sin(2 * t), **{angle: 0.2 * np.sin(2 * t)})
        polar = dict(stall_polar_alpha_rad=stall_experiment_kwargs["static_table_x_rad"],
                     stall_polar_lift=stall_experiment_kwargs["static_table_value"])
        with pytest.raises(indicial.InputError) as err:
            indicial.Experiment(coefficient="Cl", reference_length_m=0.5, airspeed_mps=30.0, runs=[run], axis=axis,
                                alpha0_rad=0.2, stall="separation", **polar)
        assert str(err.value) == ("'stall' = \"separation\": the dynamic-stall families are for a pitch experiment "
                                  "(they act on the angle of attack and its lift polar); this experiment's axis is "
                                  + axis)
        # Without stall the same experiment is accepted: the refusal is the families' axis.
        indicial.Experiment(coefficient="Cl", reference_length_m=0.5, airspeed_mps=30.0, runs=[run], axis=axis,
                            alpha0_rad=0.2)


def _cm_with_the_tables_lift(stall_experiment_kwargs):
    """The stall fixture's cycles as a pitching moment, the static table of Cm with the lift beside
    it (static_table_lift: the file's [static] table with a CL column); no stall keys."""
    kw = {k: v for k, v in stall_experiment_kwargs.items() if not k.startswith("stall")}

    def as_moment(run):
        return indicial.Run(time_s=run.time_s, alpha_rad=run.kwargs["alpha_rad"], coefficient=-0.25 * run.coefficient,
                            periodic=run.periodic, airspeed_mps=run.airspeed_mps, name=run.name)

    kw.update(coefficient="Cm", runs=[as_moment(r) for r in kw["runs"]], static_table_lift=kw["static_table_value"],
              static_table_value=-0.25 * kw["static_table_value"])
    return kw


def _first_round(experiment):
    d = indicial.diagnose(experiment, max_steps=1, rule="lr", warn=False)
    return [(c["effect"], c["term"], c["status"], c.get("fit_error"), c.get("message"))
            for c in json.loads(d.diagnosis_json())["rounds"][0]["candidates"]]


def test_written_files_keep_the_static_tables_lift(tmp_path, stall_experiment_kwargs):
    """A Cm experiment whose static table carries the lift (CL): write_files writes that column,
    so diagnose on the written files tests the same candidates, the stall families among them,
    as on the experiment in memory, from arrays and again from the files it was read from."""
    e = indicial.Experiment(**_cm_with_the_tables_lift(stall_experiment_kwargs))
    e.write_files(str(tmp_path / "a"))
    table = np.genfromtxt(tmp_path / "a" / "static_table.csv", delimiter=",", names=True, skip_header=1)
    assert table.dtype.names == ("alpha_rad", "Cm", "CL")
    assert np.array_equal(table["CL"], stall_experiment_kwargs["static_table_value"])
    expected = _first_round(e)
    assert {"separation_lag", "vortex_shedding"} <= {c[0] for c in expected}
    back = indicial.Experiment.from_toml(str(tmp_path / "a" / "experiment.toml"))
    assert _first_round(back) == expected
    back.write_files(str(tmp_path / "b"))
    assert _first_round(indicial.Experiment.from_toml(str(tmp_path / "b" / "experiment.toml"))) == expected
    assert (tmp_path / "b" / "static_table.csv").read_text() == (tmp_path / "a" / "static_table.csv").read_text()


def test_written_phase_cycles_read_back_and_fit_alike(tmp_path, cli):
    """Phase-averaged cycles (simulate --case dynamic-stall: phase columns, frequencies in the
    runs entries) written by write_files are time-column CSVs of periodic cycles, and the command
    line fits them as it fits the originals (they were refused: 'has a time column: frequency_hz
    ... only for a phase column'; a time column's frequency, the motion's, is now kept)."""
    sim = tmp_path / "sim"
    cli("simulate", "--case", "dynamic-stall", "--out", sim)
    e = indicial.Experiment.from_toml(str(sim / "experiment-CL.toml"))
    e.write_files(str(tmp_path / "w"))
    text = (tmp_path / "w" / "experiment.toml").read_text()
    assert "periodic = true" in text and "frequency_hz" in text
    for d, toml in (("a", sim / "experiment-CL.toml"), ("b", tmp_path / "w" / "experiment.toml")):
        cli("fit", toml, "--out", tmp_path / d, "--no-plots", "--quiet")
    a = json.loads((tmp_path / "a" / "fit.json").read_text())
    b = json.loads((tmp_path / "b" / "fit.json").read_text())
    for pa, pb in zip(a["parameters"], b["parameters"]):
        assert pa["name"] == pb["name"]
        assert pb["value"] == pytest.approx(pa["value"], rel=1e-9, abs=1e-12)


def test_run_groups_reach_the_experiment_file_and_a_mix_is_refused(tmp_path):
    """Run(group=...) is the runs entry's `group` (the tunnel entry a run belongs to):
    kept in Experiment.runs, written by write_files and read back by the file reader; a
    run without one beside runs with one, or an empty one, is refused as the file is."""
    runs = [indicial.Run(**sine_run(), group=g) for g in ("entry 5", "entry 6", "entry 5")]
    e = indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=30.0, runs=runs)
    assert [r["group"] for r in e.runs] == ["entry 5", "entry 6", "entry 5"]
    e.write_files(str(tmp_path / "x"))
    back = indicial.Experiment.from_toml(str(tmp_path / "x" / "experiment.toml"))
    assert [r["group"] for r in back.runs] == ["entry 5", "entry 6", "entry 5"]
    assert indicial.Run.from_dict(back.runs[1]).group == "entry 6"
    assert experiment().runs[0]["group"] is None
    with pytest.raises(indicial.InputError, match="^run 2: run 'run 2' has no 'group' while run 'run 1' has group"):
        indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=30.0,
                            runs=[indicial.Run(**sine_run(), group="a"), indicial.Run(**sine_run())])
    with pytest.raises(indicial.InputError, match="^run 1: group is empty"):
        indicial.Experiment(coefficient="Cm", reference_length_m=0.5, airspeed_mps=30.0,
                            runs=[indicial.Run(**sine_run(), group=" ")])
