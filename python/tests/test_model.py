"""indicial.Model: .coef files in and out (the bytes the command line writes), and the
runtime's refusals as exceptions."""
import zlib
from pathlib import Path

import numpy as np
import pytest

import indicial

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "tailless-model-2.coef"


def test_load_save_round_trips_the_bytes(tmp_path, cli_fit):
    for source in (EXAMPLE, cli_fit / "model.coef"):
        m = indicial.Model.load(str(source))
        m.save(str(tmp_path / source.name))
        assert (tmp_path / source.name).read_bytes() == source.read_bytes()


def test_save_refuses_to_overwrite(tmp_path):
    m = indicial.Model.load(str(EXAMPLE))
    m.save(str(tmp_path / "m.coef"))
    with pytest.raises(indicial.InputError):
        m.save(str(tmp_path / "m.coef"))
    m.save(str(tmp_path / "m.coef"), force=True)
    # A directory is named as one, not "output file exists", force or not.
    for force in (False, True):
        with pytest.raises(indicial.InputError, match="is a directory, expected the name of a file"):
            m.save(str(tmp_path), force=force)
    with pytest.raises(indicial.InputError, match="is a directory, expected a file"):
        indicial.Model.load(str(tmp_path))


def test_a_crlf_copy_of_a_written_file_loads():
    """A file written with LF lines loads after a checkout turned them into CRLF (its checksum
    is of the LF bytes; the runtime accepts both)."""
    text = EXAMPLE.read_text()
    assert "\r" not in text
    m = indicial.Model.from_text(text.replace("\n", "\r\n"))
    assert m.coefficients == indicial.Model.from_text(text).coefficients


def test_fitted_model_saved_is_read_by_the_cli(tmp_path, py_fit, cli):
    py_fit.model.save(str(tmp_path / "py.coef"))
    out = cli("coef", "check", tmp_path / "py.coef", check=False)
    assert out.returncode == 0, out.stderr


def test_properties_and_splines():
    m = indicial.Model.load(str(EXAMPLE))
    assert m.coefficients == ["Cm"] and m.axis == "pitch" and m.capacity == "default"
    lo, hi = m.envelope_rad
    x = np.linspace(lo, hi, 7)
    assert np.all(m.b(x) > 0) and m.a(x).shape == (7,)
    with pytest.raises(IndexError):
        m.b(x, lag=3)
    with pytest.raises(KeyError):
        m.a(x, coefficient="CL")


def test_bad_file_names_file_and_line(tmp_path):
    text = EXAMPLE.read_text().replace("airspeed_mps", "airspeed_mph", 1)
    (tmp_path / "bad.coef").write_text(text)
    with pytest.raises(indicial.InputError, match=r"^.*bad\.coef:\d+: "):
        indicial.Model.load(str(tmp_path / "bad.coef"))
    with pytest.raises(indicial.InputError, match="cannot|No such|not"):
        indicial.Model.load(str(tmp_path / "missing.coef"))


def with_checksum(body: str) -> str:
    """A coefficient file's text with its CRC-32 line (zlib's crc32 of every byte before it)."""
    return body + "checksum %08x\n" % zlib.crc32(body.encode())


def test_model_the_runtime_refuses(tmp_path):
    # A negative b1 (the lag would grow): the parser accepts the file, the runtime refuses it.
    body = EXAMPLE.read_text().split("checksum")[0].replace("lag_poly 1 2.5", "lag_poly 1 -2.5")
    (tmp_path / "neg.coef").write_text(with_checksum(body))
    with pytest.raises(indicial.InputError, match=r"neg\.coef: the runtime refuses the model: b_j\(x\) <= 0"):
        indicial.Model.load(str(tmp_path / "neg.coef"))
    # The unchanged text with a recomputed checksum loads (the test's checksum is right).
    indicial.Model.from_text(with_checksum(EXAMPLE.read_text().split("checksum")[0]))
