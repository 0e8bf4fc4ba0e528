"""indicial.Predictor and indicial.BatchStepper: the runtime from Python. The batch equals N
single predictors (step_batch's lane exp: within 1e-12 relative, batch.hpp); refusals keep
the instance's state; bad arrays and closed steppers raise, never crash."""
import threading
from pathlib import Path

import numpy as np
import pytest

import indicial

MODEL = Path(__file__).resolve().parents[2] / "examples" / "tailless-model-2.coef"


@pytest.fixture(scope="module")
def model():
    return indicial.Model.load(str(MODEL))


def motion(n_steps, n, dt=0.002):
    t = np.arange(1, n_steps + 1)[:, None] * dt
    phase = np.linspace(0, 1, n)[None, :]
    f = 0.5 + phase
    alpha = 0.6 - 0.5 * np.cos(2 * np.pi * f * t)
    q = 0.5 * 2 * np.pi * f * np.sin(2 * np.pi * f * t)
    return np.ascontiguousarray(alpha), np.ascontiguousarray(q)


def test_batch_equals_single_predictors(model):
    n, steps, dt = 13, 200, 0.002
    alpha, q = motion(steps, n, dt)
    batch = indicial.BatchStepper(model, n)
    batch.reset(alpha_rad=0.1)
    singles = [indicial.Predictor(model) for _ in range(n)]
    for p in singles:
        p.reset(alpha_rad=0.1)
    for k in range(steps):
        out = batch.step(alpha_rad=alpha[k], q_radps=q[k], dt_s=dt)
        expect = np.array([[p.step(alpha_rad=alpha[k, i], q_radps=q[k, i], dt_s=dt)["Cm"]] for i, p in enumerate(singles)])
        assert np.all(np.abs(out - expect) <= 1e-12 * np.maximum(np.abs(expect), 0.01))


def test_run_equals_step_by_step(model):
    n, steps, dt = 9, 50, 0.002
    alpha, q = motion(steps, n, dt)
    a, b = indicial.BatchStepper(model, n), indicial.BatchStepper(model, n)
    a.reset(alpha_rad=alpha[0])
    b.reset(alpha_rad=alpha[0])
    whole = a.run(alpha_rad=alpha, q_radps=q, dt_s=dt)
    assert whole.shape == (steps, n, 1)
    for k in range(steps):
        assert np.array_equal(b.step(alpha_rad=alpha[k], q_radps=q[k], dt_s=dt), whole[k])


def test_out_is_written_in_place(model):
    s = indicial.BatchStepper(model, 4)
    s.reset(alpha_rad=np.full(4, 0.2), airspeed_mps=np.full(4, 17.0))
    out = np.zeros((4, 1))
    got = s.step(alpha_rad=np.full(4, 0.25), q_radps=0.0, dt_s=0.01, out=out)
    assert got is out or np.shares_memory(got, out)
    assert np.all(out != 0)
    with pytest.raises(indicial.InputError, match="^out: expected a writable C-contiguous float64 array"):
        s.step(alpha_rad=0.2, q_radps=0.0, dt_s=0.01, out=np.zeros((4, 2))[:, :1])
    with pytest.raises(TypeError):
        s.step(alpha_rad=0.2, q_radps=0.0, dt_s=0.01, out=np.zeros((4, 1), dtype=np.float32))


def test_nan_instance_is_refused_and_others_step(model):
    s = indicial.BatchStepper(model, 8)
    s.reset(alpha_rad=0.2)
    before = s.step(alpha_rad=0.21, q_radps=0.1, dt_s=0.01).copy()
    angle = np.full(8, 0.25)
    angle[3] = np.nan
    with pytest.raises(indicial.StepError, match=r"the runtime refused instance 3 \(non_finite_input\)"):
        s.step(alpha_rad=angle, q_radps=0.1, dt_s=0.01)
    status = s.status
    assert status[3] == 5 and np.all(np.delete(status, 3) == 0)
    assert s.outputs[3, 0] == before[3, 0] and np.all(np.isfinite(s.outputs))
    assert s.outputs[2, 0] != before[2, 0]
    s.step(alpha_rad=angle, q_radps=0.1, dt_s=0.01, errors="keep")


@pytest.mark.parametrize("kwargs, exc, message", [
    (dict(alpha_rad=np.zeros(3), q_radps=0.0, dt_s=0.01), indicial.InputError,
     r"angle_rad: expected one number or an array of 4 \(one per instance\), got shape \(3,\)"),
    (dict(alpha_rad=np.array(["x"] * 4), q_radps=0.0, dt_s=0.01), TypeError, "angle_rad: expected an array of real"),
    (dict(alpha_rad=0.1, dt_s=0.01), indicial.InputError, "q_radps: required"),
    (dict(phi_rad=0.1, p_radps=0.0, dt_s=0.01), indicial.InputError, "phi_rad: the model's axis is pitch"),
])
def test_bad_inputs_raise(model, kwargs, exc, message):
    s = indicial.BatchStepper(model, 4)
    s.reset(alpha_rad=0.1)
    with pytest.raises(exc, match="^" + message):
        s.step(**kwargs)


def test_bad_dt_and_not_reset(model):
    s = indicial.BatchStepper(model, 2)
    with pytest.raises(indicial.StepError, match="not_reset"):
        s.step(alpha_rad=0.1, q_radps=0.0, dt_s=0.01)
    s.reset(alpha_rad=0.1)
    with pytest.raises(indicial.StepError, match="non_positive_dt"):
        s.step(alpha_rad=0.1, q_radps=0.0, dt_s=0.0)
    with pytest.raises(indicial.StepError, match="dt_too_large"):
        s.step(alpha_rad=0.1, q_radps=0.0, dt_s=5.0)


def test_closed_objects_raise(model):
    with indicial.BatchStepper(model, 2) as s:
        s.reset(alpha_rad=0.1)
    assert s.closed
    with pytest.raises(indicial.ClosedError):
        s.step(alpha_rad=0.1, q_radps=0.0, dt_s=0.01)
    with pytest.raises(indicial.ClosedError):
        len(s)
    p = indicial.Predictor(model)
    p.close()
    with pytest.raises(indicial.ClosedError):
        p.reset(alpha_rad=0.1)


def test_predictor_statuses_and_refusal_changes_nothing(model):
    p, twin = indicial.Predictor(model), indicial.Predictor(model)
    with pytest.raises(indicial.StepError, match="not_reset"):
        p.step(alpha_rad=0.1, q_radps=0.0, dt_s=0.01)
    p.reset(alpha_rad=0.1)
    twin.reset(alpha_rad=0.1)
    out = p.step(alpha_rad=5.0, q_radps=0.0, dt_s=0.01)
    twin.step(alpha_rad=5.0, q_radps=0.0, dt_s=0.01)
    assert p.last_status == "angle_clamped" and np.isfinite(out["Cm"])
    with pytest.raises(indicial.StepError, match="non_finite_input"):
        p.step(alpha_rad=float("nan"), q_radps=0.0, dt_s=0.01)
    assert p.step(alpha_rad=0.3, q_radps=0.2, dt_s=0.01) == twin.step(alpha_rad=0.3, q_radps=0.2, dt_s=0.01)


def test_threads_step_their_own_steppers_without_the_gil(model):
    alpha, q = motion(400, 256)
    results = {}

    def work(i):
        s = indicial.BatchStepper(model, 256)
        s.reset(alpha_rad=alpha[0])
        results[i] = s.run(alpha_rad=alpha, q_radps=q, dt_s=0.002)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert np.array_equal(results[0], results[1]) and np.array_equal(results[1], results[2])


def test_outputs_after_reset_are_the_reset_states_outputs(model):
    # They read 0 until the first step; now each row is the state's output at rest (the C API's
    # indicial_evaluate), i.e. a step to the same angle at rest.
    n = 4
    angles = np.array([0.1, 0.3, 0.6, 0.9])
    batch = indicial.BatchStepper(model, n)
    batch.reset(alpha_rad=angles)
    at_reset = np.array(batch.outputs)
    assert np.all(at_reset != 0.0)
    stepped = batch.step(alpha_rad=angles, q_radps=np.zeros(n), dt_s=0.002)
    assert np.allclose(at_reset, stepped, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("row", [0, 1, 2, 3])
def test_run_raises_on_a_refusal_at_any_time_step(model, row):
    """A NaN at any row of run's input raises StepError naming that time step, and status
    keeps the instance's refusal (only a refusal at the last row raised before)."""
    s = indicial.BatchStepper(model, 3)
    s.reset(alpha_rad=0.3)
    a = np.full((4, 3), 0.3)
    a[row, 1] = np.nan
    with pytest.raises(indicial.StepError, match=rf"^run \(time step {row} first refused\): .*instance 1 "):
        s.run(alpha_rad=a, q_radps=np.zeros((4, 3)), dt_s=1e-3)
    assert list(s.status) == [0, 5, 0]  # 5: non_finite_input, kept although later rows stepped
    # errors="keep" returns the history; the refused lane repeats its previous row there.
    s2 = indicial.BatchStepper(model, 3)
    s2.reset(alpha_rad=0.3)
    before = s2.outputs.copy()
    out = s2.run(alpha_rad=a, q_radps=np.zeros((4, 3)), dt_s=1e-3, errors="keep")
    assert list(s2.status) == [0, 5, 0]
    assert np.array_equal(out[row, 1], out[row - 1, 1] if row > 0 else before[1])


def test_step_keeps_the_airspeed_of_reset(model):
    """An airspeed not given to step is the last reset's (or accepted step's), never silently
    the model's reference airspeed."""
    v = model.airspeed_mps * 1.3
    alpha, q = motion(60, 2, 0.002)
    given, sticky = indicial.Predictor(model), indicial.Predictor(model)
    given.reset(alpha_rad=alpha[0, 0], airspeed_mps=v)
    sticky.reset(alpha_rad=alpha[0, 0], airspeed_mps=v)
    reference = indicial.Predictor(model)
    reference.reset(alpha_rad=alpha[0, 0])
    differs = False
    for k in range(60):
        a = given.step(alpha_rad=alpha[k, 0], q_radps=q[k, 0], dt_s=0.002, airspeed_mps=v)["Cm"]
        b = sticky.step(alpha_rad=alpha[k, 0], q_radps=q[k, 0], dt_s=0.002)["Cm"]
        r = reference.step(alpha_rad=alpha[k, 0], q_radps=q[k, 0], dt_s=0.002)["Cm"]
        assert a == b
        differs = differs or abs(a - r) > 1e-6
    assert differs  # the airspeed matters on this motion
    bg, bs = indicial.BatchStepper(model, 2), indicial.BatchStepper(model, 2)
    bg.reset(alpha_rad=alpha[0], airspeed_mps=v)
    bs.reset(alpha_rad=alpha[0], airspeed_mps=v)
    assert np.array_equal(bg.run(alpha_rad=alpha, q_radps=q, dt_s=0.002, airspeed_mps=v),
                          bs.run(alpha_rad=alpha, q_radps=q, dt_s=0.002))


def test_predictor_refuses_text(model):
    p = indicial.Predictor(model)
    with pytest.raises(TypeError, match="angle: expected a real number, got str"):
        p.reset(alpha_rad="0.3")
    p.reset(alpha_rad=0.3)
    with pytest.raises(TypeError, match="angle: expected a real number, got str"):
        p.step(alpha_rad="0.3", q_radps=0.0, dt_s=1e-3)


def test_run_names_the_first_refusal_in_time(model):
    s = indicial.BatchStepper(model, 3)
    s.reset(alpha_rad=0.3)
    a = np.full((5, 3), 0.3)
    a[3, 0] = np.nan  # instance 0 refused later
    a[1, 2] = np.nan  # instance 2 refused first
    with pytest.raises(indicial.StepError, match=r"^run \(time step 1 first refused\): .*instance 2 \(non_finite_input\) and 1 more"):
        s.run(alpha_rad=a, q_radps=np.zeros((5, 3)), dt_s=1e-3)
    assert list(s.status) == [5, 0, 5]


def test_reset_without_airspeed_is_the_reference_and_errors_is_checked_first(model):
    v = model.airspeed_mps * 1.3
    alpha, q = motion(30, 2, 0.002)
    b, ref = indicial.BatchStepper(model, 2), indicial.BatchStepper(model, 2)
    b.reset(alpha_rad=alpha[0], airspeed_mps=v)
    b.reset(alpha_rad=alpha[0])  # back at the reference airspeed, as Predictor.reset
    ref.reset(alpha_rad=alpha[0])
    assert np.array_equal(b.run(alpha_rad=alpha, q_radps=q, dt_s=0.002), ref.run(alpha_rad=alpha, q_radps=q, dt_s=0.002))
    before = b.outputs.copy()
    with pytest.raises(indicial.InputError, match="^errors: expected 'raise' or 'keep'"):
        b.step(alpha_rad=alpha[0] + 0.1, q_radps=0.0, dt_s=0.002, errors="bogus")
    with pytest.raises(indicial.InputError, match="^errors: expected 'raise' or 'keep'"):
        b.reset(alpha_rad=alpha[0] + 0.1, errors="bogus")
    assert np.array_equal(b.outputs, before)  # nothing changed


def test_clamped_steps_count_a_runs_clamping_its_last_status_hides(model):
    """clamped_steps: per instance, the steps of the last run (or step) whose angle was clamped,
    as single predictors' statuses count them; the last status alone says ok."""
    lo, hi = model.envelope_rad
    n, steps, dt = 3, 40, 0.002
    alpha = np.full((steps, n), 0.5 * (lo + hi))
    alpha[10:15, 0] = hi + 0.05       # five steps beyond the envelope, then back
    alpha[20:21, 2] = lo - 0.05       # one
    q = np.zeros_like(alpha)
    batch = indicial.BatchStepper(model, n)
    batch.reset(alpha_rad=alpha[0])
    batch.run(alpha_rad=alpha, q_radps=q, dt_s=dt)
    singles = []
    for i in range(n):
        p = indicial.Predictor(model)
        p.reset(alpha_rad=alpha[0, i])
        count = 0
        for k in range(steps):
            p.step(alpha_rad=alpha[k, i], q_radps=0.0, dt_s=dt)
            count += p.last_status == "angle_clamped"
        singles.append(count)
    assert list(batch.clamped_steps) == singles == [5, 0, 1]
    assert list(batch.status) == [0, 0, 0]
    batch.step(alpha_rad=np.array([hi + 0.05, 0.6, 0.6]), q_radps=0.0, dt_s=dt)   # the last call's only
    assert list(batch.clamped_steps) == [1, 0, 0]
    batch.reset(alpha_rad=0.6)
    assert list(batch.clamped_steps) == [0, 0, 0]
