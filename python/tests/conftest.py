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
