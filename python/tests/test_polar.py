"""indicial.quasi_static_polar: `indicial polar` in memory -- the same table as the command's
CSV, the rising samples' recipe, and bad options raising InputError."""
import math

import numpy as np
import pytest

import indicial


def _static(x):
    return 5.5 * x - 8.0 * x ** 3


def _write_cycles(tmp_path):
    """Three quasi-static cycles (phase_rad, alpha_deg, CL): on the downstroke above 10 deg the
    flow is still separated, 0.3 below the static curve."""
    runs = []
    for c in range(3):
        ph = 2 * math.pi * np.arange(200) / 200
        x = np.radians(8 + 10 * np.sin(ph + 0.37 * c))
        falling = np.cos(ph + 0.37 * c) < 0
        cl = _static(x) - np.where(falling & (x > np.radians(10)), 0.3, 0.0)
        name = f"qs{c}.csv"
        with open(tmp_path / name, "w") as f:
            f.write("phase_rad,alpha_deg,CL\n")
            for p, a, v in zip(ph, np.degrees(x), cl):
                f.write(f"{p!r},{a!r},{v!r}\n")
        runs.append(f'{{file = "{name}", frequency_hz = 0.1}}')
    path = tmp_path / "qs.toml"
    path.write_text('axis = "pitch"\ncoefficient = "CL"\nreference_length_m = 0.275\nairspeed_mps = 40\n'
                    f"runs = [{', '.join(runs)}]\n")
    return path


def test_polar_is_the_commands_table(tmp_path, cli):
    path = _write_cycles(tmp_path)
    p = indicial.quasi_static_polar(path)
    assert p.runs == 3 and len(p.x_rad) >= 19 and list(p.values) == ["CL"]
    assert np.all(np.diff(p.x_rad) > 0)
    assert np.max(np.abs(p.values["CL"] - _static(p.x_rad))) < 1e-3  # the hysteresis left out
    both = indicial.quasi_static_polar(path, stroke="both")
    mid = (both.x_rad > np.radians(11)) & (both.x_rad < np.radians(17))
    assert np.max(_static(both.x_rad[mid]) - both.values["CL"][mid]) > 0.1
    # The command's CSV: the same rows as p.csv below their comment lines.
    cli("polar", path, "--out", tmp_path / "cli.csv")
    rows = lambda text: [line for line in text.splitlines() if not line.startswith("#")]
    assert rows((tmp_path / "cli.csv").read_text()) == rows(p.csv)
    p.write(str(tmp_path / "static.csv"))
    with pytest.raises(indicial.InputError, match="exists"):
        p.write(str(tmp_path / "static.csv"))
    with pytest.raises(indicial.InputError):  # never onto an input, force or not
        p.write(str(tmp_path / "qs1.csv"), force=True)
    assert (tmp_path / "qs1.csv").read_text().startswith("phase_rad,alpha_deg,CL")
    held = indicial.quasi_static_polar(path, hold_deg=2.0)
    assert held.held_rows == 2 and len(held.x_rad) == len(p.x_rad) + 2


def test_polar_bad_options_raise(tmp_path):
    path = _write_cycles(tmp_path)
    with pytest.raises(indicial.InputError, match="bin width must be > 0"):
        indicial.quasi_static_polar(path, bin_deg=0.0)
    with pytest.raises(indicial.InputError, match="expected one of 'outward', 'rising', 'both'"):
        indicial.quasi_static_polar(path, stroke="up")
    with pytest.raises(indicial.InputError, match="held fewer than 100000 samples"):
        indicial.quasi_static_polar(path, min_samples=100000)
    with pytest.raises(indicial.InputError, match="a static table holds at most 64"):
        indicial.quasi_static_polar(path, bin_deg=0.2, min_samples=1)
