"""indicial.simulate and indicial.simulation_case equal `indicial simulate` (the reference
integration and its noise stream)."""
import csv

import numpy as np
import pytest

import indicial


def read_csv(path):
    rows = [r for r in csv.reader(l for l in open(path) if not l.startswith("#"))]
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


def test_simulate_equals_cli(case_dir, cli, tmp_path):
    spec = "sine:alpha0_deg=30,amp_deg=20,freq_hz=0.7,cycles=2,dt_s=0.01"
    cli("simulate", "--model", case_dir / "truth.coef", "--motion", spec, "--snr", "30", "--seed", "9",
        "--out", tmp_path / "s.csv")
    expected = read_csv(tmp_path / "s.csv")
    s = indicial.simulate(indicial.Model.load(str(case_dir / "truth.coef")), motion=spec, snr=30, seed=9)
    assert np.array_equal(s.time_s, expected["time_s"])
    assert np.allclose(s.measured["Cm"], expected["Cm"], rtol=0, atol=1e-12)
    assert np.allclose(s.true["Cm"], expected["Cm_true"], rtol=0, atol=1e-12)


def test_simulation_case_equals_cli_files(case_dir):
    case = indicial.simulation_case("tailless-model-1", snr=40, seed=3)  # case_dir's arguments
    e = indicial.Experiment.from_toml(str(case_dir / "experiment.toml"))
    for sim, run in zip(case.runs, e.runs):
        assert sim.name == run["name"].split("/")[-1]
        assert np.allclose(sim.measured["Cm"], run["coefficient"], rtol=0, atol=1e-12)
        assert np.allclose(sim.motion_angle_rad, run["motion_angle_rad"], rtol=0, atol=1e-12)


def test_simulate_from_arrays_and_bad_input(case_dir):
    m = indicial.Model.load(str(case_dir / "truth.coef"))
    t = np.arange(300) * 0.01
    s = indicial.simulate(m, time_s=t, alpha_rad=0.5 + 0.2 * np.sin(t))
    assert s.true["Cm"].shape == (300,) and np.array_equal(s.measured["Cm"], s.true["Cm"])
    with pytest.raises(indicial.InputError, match="^--motion: "):
        indicial.simulate(m, motion="square:amp_deg=3")
    with pytest.raises(indicial.InputError, match="^time_s: a sampled motion must be uniform"):
        indicial.simulate(m, time_s=t ** 1.5, alpha_rad=np.sin(t))
    with pytest.raises(indicial.InputError, match="^--case: "):
        indicial.simulation_case("no-such-case")


def test_simulate_integrates_dynamic_stall_families_as_the_cli(cli, tmp_path):
    """A model with dynamic-stall families: the reference integration includes their states
    (simulate.hpp); the Python call equals `indicial simulate --model`, and its unsteady part
    holds the families' delta."""
    from conftest import REPO
    coef = REPO / "examples" / "dynamic-stall-lift-moment.coef"
    spec = "sine:alpha0_deg=15,amp_deg=10,freq_hz=2,cycles=2,dt_s=0.002"
    cli("simulate", "--model", coef, "--motion", spec, "--out", tmp_path / "s.csv")
    expected = read_csv(tmp_path / "s.csv")
    s = indicial.simulate(indicial.Model.load(str(coef)), motion=spec)
    for name in ("CL", "Cm"):
        assert np.allclose(s.true[name], expected[name + "_true"], rtol=0, atol=1e-12)
    # The unsteady part y_true holds the families' delta: far from the lags' alone.
    assert np.max(np.abs(s.y_true["CL"])) > 0.05
