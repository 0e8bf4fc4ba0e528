"""Shared fixtures: the command line (INDICIAL_CLI, set by ctest; else build/tools/indicial),
a simulated Example 1 case written by `indicial simulate --case`, and the command line's fit
of it. Session-scoped: each is made once per pytest run."""
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def cli_path() -> Path:
    given = os.environ.get("INDICIAL_CLI")
    path = Path(given) if given else REPO / "build" / "tools" / "indicial"
    if not path.is_file():
        pytest.fail(f"the indicial command line is needed to compare with ({path}); build it or set INDICIAL_CLI")
    return path


def run_cli(*args, check=True):
    return subprocess.run([str(cli_path()), *map(str, args)], capture_output=True, text=True, check=check)


@pytest.fixture(scope="session")
def cli():
    return run_cli


@pytest.fixture(scope="session")
def case_dir(tmp_path_factory):
    """Example 1, Model I (tailless-model-1), SNR 40, seed 3: run CSVs, experiment.toml, truth.coef."""
    d = tmp_path_factory.mktemp("case") / "model1"
    run_cli("simulate", "--case", "tailless-model-1", "--snr", "40", "--seed", "3", "--out", d)
    return d


@pytest.fixture(scope="session")
def cli_fit(case_dir, tmp_path_factory):
    """`indicial fit` of the case: DIR with fit.json and model.coef."""
    out = tmp_path_factory.mktemp("clifit") / "fit"
    run_cli("fit", case_dir / "experiment.toml", "--out", out, "--no-plots", "--quiet")
    return out


@pytest.fixture(scope="session")
def py_fit(case_dir):
    import indicial
    return indicial.fit(indicial.Experiment.from_toml(str(case_dir / "experiment.toml")), warn=False)


@pytest.fixture
def stall_experiment_kwargs():
    """Experiment(...) keywords of a measured-like pitching-airfoil experiment: two periodic
    C_L cycles (alpha 4..24 deg, k = 0.1, at 30 and 20 m/s) of a NACA 0012-like lift polar
    (Kirchhoff with Leishman-Beddoes' f0) seen 4 ms late, with white noise (sigma 0.01, seeded),
    the polar as the static table (-12..36 deg), the separation and vortex families, T2 and Tvl
    held at known values. The data need not come from the stall model: the tests that use it
    compare two paths to the same fit, or refuse bad keywords."""
    import numpy as np
    import indicial
    deg = np.pi / 180

    def lift(x):
        a = np.abs(x) / deg
        f0 = np.where(a <= 15.25, 1 - 0.3 * np.exp((a - 15.25) / 3), 0.04 + 0.66 * np.exp((15.25 - a) / 2.3))
        return 6.3 * x * ((1 + np.sqrt(f0)) / 2) ** 2

    length_m = 0.275

    def cycle(airspeed_mps, seed):
        omega = 0.1 * airspeed_mps / length_m
        t = np.arange(128) * (2 * np.pi / omega) / 128
        alpha = (14 - 10 * np.cos(omega * t)) * deg
        late = (14 - 10 * np.cos(omega * (t - 0.004))) * deg
        noise = 0.01 * np.random.default_rng(seed).standard_normal(t.size)
        return indicial.Run(time_s=t, alpha_rad=alpha, coefficient=lift(late) + noise, periodic=True,
                            airspeed_mps=airspeed_mps, name=f"cycle at {airspeed_mps} m/s")

    table_rad = np.arange(-12, 37) * deg
    return dict(coefficient="CL", reference_length_m=length_m, airspeed_mps=30.0,
                runs=[cycle(30.0, 1), cycle(20.0, 2)], a_powers=[0], b1_powers=[0],
                static_table_x_rad=table_rad, static_table_value=lift(table_rad),
                stall="separation_and_vortex", stall_T1_start=2.5, stall_known={"T2": 1.5, "Tvl": 7.0})
