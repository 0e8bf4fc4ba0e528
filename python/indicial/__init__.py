"""indicial: identify nonlinear unsteady aerodynamic models and run them, from Python.

The same C++ fitter and runtime as the ``indicial`` command line (one set of sources), over
numpy arrays. Angles are in rad, rates in rad/s, airspeeds in m/s, times in s, lengths in m;
every name says its unit.

    import indicial
    e = indicial.Experiment.from_toml("experiment.toml")          # or from arrays:
    e = indicial.Experiment(coefficient="Cm", reference_length_m=0.1, airspeed_mps=30.0,
                            runs=[indicial.Run(time_s=t, alpha_rad=a, coefficient=cm)],
                            a_powers=[0, 1, 2], b1_powers=[0])
    r = indicial.fit(e)                    # equation error, stepwise, ML output error
    for p in r.parameters: print(p.name, p.value, p.cr_bound, p.cr_bound_colored)
    r.model.save("model.coef")             # the bytes `indicial fit` writes
    d = indicial.diagnose(e)               # the missing effect, named, added
    p = indicial.predict(r.model, time_s=t, alpha_rad=a)
    s = indicial.BatchStepper(r.model, 1024); s.reset(alpha_rad=0.1)
    out = s.step(alpha_rad=a_now, q_radps=q_now, dt_s=0.001)   # (1024, n_coefficients)

Errors are exceptions carrying the command line's one-line messages: ``InputError``
(a ValueError: bad input, a model the runtime refuses), ``StepError`` (the runtime refused a
step), ``ClosedError`` (a closed stepper). Warnings of the fitter are issued as
``IndicialWarning`` and kept in each result's ``warnings``.
"""
from __future__ import annotations

import math
import warnings as _warnings
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

import numpy as np

from . import _indicial
from ._indicial import ClosedError, InputError, StepError

__version__ = _indicial.__version__

__all__ = [
    "Experiment", "Run", "fit", "diagnose", "predict", "simulate", "simulation_case", "quasi_static_polar", "read_runs",
    "QuasiStaticPolar",
    "Model", "Predictor", "BatchStepper", "FitResult", "Parameter", "Diagnosis",
    "Prediction", "InputError", "StepError", "ClosedError", "IndicialWarning",
]


class IndicialWarning(UserWarning):
    """A plausible mistake in the input or a result to read with care (the command line's
    ``indicial: warning: ...`` lines)."""


def _warn(lines: Sequence[str]) -> None:
    for line in lines:
        _warnings.warn(line, IndicialWarning, stacklevel=3)


# Motion names per axis: the angle and rate columns of the run files (docs/formats.md).
_ANGLE = {"pitch": "alpha_rad", "roll": "phi_rad", "yaw": "psi_rad"}
_RATE = {"pitch": "q_radps", "roll": "p_radps", "yaw": "r_radps"}


_MOTION_NAMES = frozenset(_ANGLE.values()) | frozenset(_RATE.values())


def _real(value, name: str) -> float:
    """float(value), refusing text: float("0.3") would turn a string angle into a number
    (docs/python.md: strings raise TypeError)."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name}: expected a real number, got {type(value).__name__}")
    return float(value)


def _motion(axis: str, kwargs: dict, need_rate: bool = False):
    """The motion angle (rad) and rate (rad/s, or None) named for `axis` in kwargs; refuses
    another axis' names (a roll model given alpha_rad is a mistake, not a synonym)."""
    angle_name, rate_name = _ANGLE[axis], _RATE[axis]
    angle, rate = kwargs.get(angle_name), kwargs.get(rate_name)
    if angle is not None and (rate is not None or not need_rate) and \
            len(kwargs) == (angle_name in kwargs) + (rate_name in kwargs):
        return angle, rate  # the fast path of a stepping loop
    for name, value in kwargs.items():
        if name not in _MOTION_NAMES:
            raise TypeError(f"unexpected keyword argument '{name}'")
        if value is not None and name not in (angle_name, rate_name):
            raise InputError(f"{name}: the model's axis is {axis}: give {angle_name} and {rate_name}")
    if angle is None:
        raise InputError(f"{angle_name}: required (the {axis} motion angle, rad)")
    if need_rate and rate is None:
        raise InputError(f"{rate_name}: required (the {axis} rate, rad/s)")
    return angle, rate


# --------------------------------------------------------------------------------------------
# Experiments
# --------------------------------------------------------------------------------------------
class Run:
    """One tunnel run from arrays, for ``Experiment(runs=[...])``.

    Parameters (all 1-D arrays of one length, at least 11 samples):
      time_s         sample times, s, strictly increasing (uniform within 1e-6 relative
                     unless time_grid="nonuniform")
      alpha_rad | phi_rad | psi_rad   the motion angle of the experiment's axis, rad
      q_radps | p_radps | r_radps     its rate, rad/s; when omitted, the Savitzky-Golay
                     derivative of the angle (as for a run file without a rate column)
      coefficient    the measured coefficient (dimensionless)
      periodic       True for one ensemble-averaged cycle (periodic steady state)
      airspeed_mps   this run's airspeed, m/s (default: the experiment's)
      name           how messages and results name the run
      group          the tunnel entry, campaign or session the run belongs to (the experiment
                     file's runs key ``group``): ``diagnose(..., cv_unit="group")`` leaves
                     whole groups out of its cross-validation (docs/diagnose.md, "Groups");
                     either every run of an Experiment has a group or none does

    ``Run.from_dict(d)`` takes a run as ``Experiment.runs`` and ``read_runs`` give it (the
    axis-neutral ``motion_angle_rad`` and ``rate_radps``, whatever the axis), e.g. to refit
    some of an experiment's runs.
    """

    def __init__(self, *, time_s, coefficient, alpha_rad=None, q_radps=None, phi_rad=None, p_radps=None,
                 psi_rad=None, r_radps=None, periodic: bool = False, airspeed_mps: Optional[float] = None,
                 time_grid: str = "uniform", name: Optional[str] = None, group: Optional[str] = None):
        self.kwargs = dict(alpha_rad=alpha_rad, q_radps=q_radps, phi_rad=phi_rad, p_radps=p_radps,
                           psi_rad=psi_rad, r_radps=r_radps)
        self.time_s, self.coefficient = time_s, coefficient
        self.periodic, self.airspeed_mps, self.time_grid, self.name = periodic, airspeed_mps, time_grid, name
        self.group = group
        self._neutral = None  # (angle, rate) of from_dict: the experiment's axis, whatever it is
        self._from = (None, None)  # from_dict: (coefficient_name, axis) of the dict

    @classmethod
    def from_dict(cls, d: dict) -> "Run":
        """A Run from one of ``Experiment.runs`` or ``read_runs``: its ``time_s``,
        ``motion_angle_rad``, ``rate_radps``, ``coefficient``, ``periodic``, ``airspeed_mps``,
        ``time_grid``, ``name`` and ``group`` (other keys ignored). The motion is taken as the angle of
        whichever axis the Experiment it joins has: the dicts carry no axis-specific names."""
        missing = [k for k in ("time_s", "motion_angle_rad", "coefficient") if k not in d]
        if missing:
            raise InputError(f"Run.from_dict: missing {', '.join(missing)} (a run of Experiment.runs or read_runs)")
        r = cls(time_s=d["time_s"], coefficient=d["coefficient"], periodic=bool(d.get("periodic", False)),
                airspeed_mps=d.get("airspeed_mps"), time_grid=d.get("time_grid", "uniform"), name=d.get("name"),
                group=d.get("group"))
        r._neutral = (d["motion_angle_rad"], d.get("rate_radps"))
        # What the dict says it is, for Experiment to check (a C_L run in a Cm experiment, a
        # roll run in a pitch one, would be fitted silently otherwise).
        r._from = (d.get("coefficient_name"), d.get("axis"))
        return r

    def _dict(self, axis: str) -> dict:
        angle, rate = self._neutral if self._neutral is not None else _motion(axis, self.kwargs)
        return dict(time_s=self.time_s, motion_angle_rad=angle, rate_radps=rate, coefficient=self.coefficient,
                    periodic=bool(self.periodic), airspeed_mps=self.airspeed_mps, time_grid=self.time_grid,
                    name=self.name, group=self.group)


class Experiment:
    """Tunnel runs and the model to fit to them (the experiment file's content).

    ``Experiment.from_toml(path)`` reads an experiment file and its run files exactly as
    ``indicial fit`` does (same checks, same messages). The constructor builds one from arrays:

      coefficient          "Cm", "CL", ... (the measured coefficient)
      reference_length_m   l (mean chord / 2 in pitch, span / 2 in roll and yaw), m
      airspeed_mps         V, m/s
      runs                 a list of ``Run``
      axis                 "pitch" (default), "roll" or "yaw"; alpha0_rad for roll and yaw
      static_polynomial    C_a(x) coefficients of x^0, x^1, ... (x in rad)
      static_table_x_rad, static_table_value
                           instead of static_polynomial: the static curve as a table
                           ([static] table): x = alpha (pitch) or beta (roll, yaw) in rad,
                           strictly increasing, 2..64 rows covering the runs' x; the measured
                           coefficient's value at each (linear between rows)
      static_table_lift    a pitch experiment of another coefficient than CL (a Cm): the lift C_L
                           at each static_table_x_rad, as the [static] table file's CL column;
                           ``diagnose`` offers the dynamic-stall families with it
      rotary_polynomial    a priori C_aq(x) coefficients of x^0, x^1, ...
      rotary_estimate      True: the two-stage loop re-estimates C_aq(x) from
                           rotary_powers / rotary_knots_rad candidates
      a_powers, a_knots_rad    a(x) terms (x^i, and (x - k)_+^2 knots in rad, strictly increasing
                               and inside the runs' x, as every knot keyword); default 0, 1, 2
      b1_powers, b1_knots_rad  b1(x) terms (1/s at V); default the constant b1_0
      bias                 the state-equation constant con
      structure            "fixed" or "stepwise" (the terms are then a candidate pool)
      lags                 number of lag states (1 or 2, the runtime's capacity; 3 is refused
                           as the file's model.lags = 3 is)
      delay                "none" (default) or "estimated": a pure delay of the unsteady forcing,
                           parameter delay_s (s at V); delay_start_s its start value, s in [0, 1]
      The dynamic-stall families ([model] stall keys of docs/formats.md, same names and checks):
      stall                "none" (default), "separation" (the separation state f) or
                           "separation_and_vortex" (f and the leading-edge vortex); pitch only
      stall_polar_alpha_rad, stall_polar_lift
                           the static lift polar (alpha in rad, strictly increasing; C_L); default:
                           the static table, when the coefficient is stall_polar_column
      stall_polar_column   the polar's lift column, default "CL"
      stall_attached_max_deg  polar rows with abs(alpha) <= this (deg, default 8) are its
                           attached part (C_Na, alpha_0)
      stall_f0_correction_powers, stall_f0_correction_knots_rad
                           a fitted correction of f0(x): powers of x and (x - k)_+ knots, k in rad
      stall_reattachment   "as_separation" (default: T1 both ways) or "estimated": the separation
                           state's own time constant T1r while the flow reattaches
      stall_forcing_lag    "delay" (default: x - T2 (l/V) x') or "first_order": the forcing angle
                           as a first-order filter of time constant T2 (docs/formats.md)
      stall_hysteresis     "none" (default) or "estimated": the separation state's static
                           hysteresis dxr (rad): the flow reattaches only dxr closer to alpha_0
                           than it separated, at any rate
      stall_dxr_start      start value of dxr (rad, in (0, 0.349]; default 0.035 = 2 deg; needs
                           stall_hysteresis)
      stall_lag_limit      "none" (default) or "estimated": the forcing angle's lag limited to D
                           (rad), x_e = x - D tanh(T2 (l/V) x' / D); with the delay forcing lag only
      stall_dxl_start      start value of D (rad, in (0, 0.349]; default 0.1 = 5.7 deg; needs
                           stall_lag_limit)
      stall_T1_start, stall_T2_start, stall_Tv_start, stall_Tvl_start, stall_T1r_start
                           start values in semichords (units of l / V; default 3, 1.5, 6, 7 and for
                           T1r T1's start; T2 >= 0, the others > 0; stall_T1r_start needs
                           stall_reattachment)
      stall_CN1_start      start value of the shedding threshold (C_N; default from the polar)
      stall_known          {name: value} of stall parameters held at known values, not estimated:
                           T1, T2 (l / V), k0, k1, k2, and with the vortex CN1 (C_N), Tv, Tvl
                           (l / V), cv, xv, with stall_reattachment T1r, with stall_hysteresis dxr
                           and with stall_lag_limit dxl (rad); e.g. {"T1": 3.4, "T2": 1.1}
                           from the C_L fit's model
      Every stall_* keyword needs ``stall``. Bad values raise InputError naming the keyword, with
      the experiment file's messages.
    """

    def __init__(self, *, coefficient: str, reference_length_m: float, airspeed_mps: float,
                 runs: Sequence[Run], axis: str = "pitch", alpha0_rad: float = 0.0,
                 static_polynomial: Sequence[float] = (), rotary_polynomial: Sequence[float] = (),
                 rotary_estimate: bool = False, rotary_powers: Optional[Sequence[int]] = None,
                 rotary_knots_rad: Sequence[float] = (), a_powers: Sequence[int] = (0, 1, 2),
                 a_knots_rad: Sequence[float] = (), b1_powers: Sequence[int] = (0,),
                 b1_knots_rad: Sequence[float] = (), bias: bool = False, structure: str = "fixed",
                 lags: int = 1, name: str = "experiment", static_table_x_rad=None, static_table_value=None,
                 static_table_lift=None,
                 delay: Optional[str] = None, delay_start_s: Optional[float] = None, stall: Optional[str] = None,
                 stall_polar_alpha_rad=None, stall_polar_lift=None, stall_polar_column: Optional[str] = None,
                 stall_attached_max_deg: Optional[float] = None,
                 stall_f0_correction_powers: Optional[Sequence[int]] = None, stall_f0_correction_knots_rad=None,
                 stall_T1_start: Optional[float] = None, stall_T2_start: Optional[float] = None,
                 stall_CN1_start: Optional[float] = None, stall_Tv_start: Optional[float] = None,
                 stall_Tvl_start: Optional[float] = None, stall_known: Optional[Dict[str, float]] = None,
                 stall_reattachment: Optional[str] = None, stall_T1r_start: Optional[float] = None,
                 stall_forcing_lag: Optional[str] = None, stall_hysteresis: Optional[str] = None,
                 stall_dxr_start: Optional[float] = None, stall_lag_limit: Optional[str] = None,
                 stall_dxl_start: Optional[float] = None):
        if axis not in _ANGLE:
            raise InputError(f"axis: expected one of 'pitch', 'roll', 'yaw', found '{axis}'")
        config = dict(coefficient=coefficient, reference_length_m=float(reference_length_m),
                      airspeed_mps=float(airspeed_mps), axis=axis, alpha0_rad=float(alpha0_rad),
                      static_polynomial=list(static_polynomial), rotary_polynomial=list(rotary_polynomial),
                      rotary_estimate=bool(rotary_estimate),
                      rotary_powers=None if rotary_powers is None else list(rotary_powers),
                      rotary_knots_rad=list(rotary_knots_rad), a_powers=list(a_powers), a_knots_rad=list(a_knots_rad),
                      b1_powers=list(b1_powers), b1_knots_rad=list(b1_knots_rad), bias=bool(bias),
                      structure=structure, lags=int(lags), name=name)
        # The keywords of the experiment file's extensions: None is "not given" (the file's
        # default), as a key left out of the file.
        config.update(static_table_x_rad=static_table_x_rad, static_table_value=static_table_value,
                      static_table_lift=static_table_lift, delay=delay,
                      delay_start_s=delay_start_s, stall=stall, stall_polar_alpha_rad=stall_polar_alpha_rad,
                      stall_polar_lift=stall_polar_lift, stall_polar_column=stall_polar_column,
                      stall_attached_max_deg=stall_attached_max_deg,
                      stall_f0_correction_powers=None if stall_f0_correction_powers is None
                      else list(stall_f0_correction_powers),
                      stall_f0_correction_knots_rad=stall_f0_correction_knots_rad, stall_T1_start=stall_T1_start,
                      stall_T2_start=stall_T2_start, stall_CN1_start=stall_CN1_start, stall_Tv_start=stall_Tv_start,
                      stall_Tvl_start=stall_Tvl_start, stall_reattachment=stall_reattachment,
                      stall_T1r_start=stall_T1r_start, stall_forcing_lag=stall_forcing_lag,
                      stall_hysteresis=stall_hysteresis, stall_dxr_start=stall_dxr_start,
                      stall_lag_limit=stall_lag_limit, stall_dxl_start=stall_dxl_start,
                      stall_known=None if stall_known is None else dict(stall_known))
        for i, r in enumerate(runs):
            if not isinstance(r, Run):
                raise TypeError(f"runs[{i}]: expected indicial.Run, got {type(r).__name__}")
            name, run_axis = r._from
            if name is not None and name != coefficient:
                raise InputError(f"runs[{i}]: Run.from_dict of a {name} run; the experiment's coefficient is {coefficient}")
            if run_axis is not None and run_axis != axis:
                raise InputError(f"runs[{i}]: Run.from_dict of a {run_axis} run; the experiment's axis is {axis}")
        self._e = _indicial._make_experiment(config, [r._dict(axis) for r in runs])

    @classmethod
    def _wrap(cls, e) -> "Experiment":
        self = cls.__new__(cls)
        self._e = e
        return self

    @classmethod
    def from_toml(cls, path: str, coefficient: Optional[str] = None) -> "Experiment":
        """Reads an experiment file and every run it names (``indicial fit``'s reader). A file
        with several coefficients needs ``coefficient=`` (or use ``Experiment.all_from_toml``)."""
        return cls._wrap(_indicial._load_experiment(str(path), coefficient or ""))

    @classmethod
    def all_from_toml(cls, path: str) -> List["Experiment"]:
        """One Experiment per coefficient of the file, in the order of ``coefficients``."""
        return [cls._wrap(e) for e in _indicial._load_experiments(str(path))]

    path = property(lambda self: self._e.path, doc="the experiment file (or the name given)")
    axis = property(lambda self: self._e.axis, doc='"pitch", "roll" or "yaw"')
    coefficient = property(lambda self: self._e.coefficient)
    reference_length_m = property(lambda self: self._e.reference_length_m, doc="l, m")
    airspeed_mps = property(lambda self: self._e.airspeed_mps, doc="V, m/s")
    alpha0_rad = property(lambda self: self._e.alpha0_rad, doc="roll and yaw: the fixed angle of attack, rad")
    structure = property(lambda self: self._e.structure)
    warnings = property(lambda self: list(self._e.warnings), doc="the readers' warnings, one line each")
    notes = property(lambda self: list(self._e.notes))
    data_range_rad = property(lambda self: (self._e.data_x_min_rad, self._e.data_x_max_rad),
                              doc="(min, max) of the model angle x over every sample, rad")

    @property
    def runs(self) -> List[dict]:
        """Each run's arrays: time_s, motion_angle_rad, rate_radps (rad/s), coefficient (the
        measured values of ``coefficient_name``), with periodic, airspeed_mps, time_grid, name
        and axis: ``predict(model, run=r)`` predicts and scores it, ``Run.from_dict(r)`` makes
        it a Run again."""
        return [dict(r, coefficient_name=self._e.coefficient, axis=self.axis) for r in self._e.runs]

    def write_files(self, directory: str, force: bool = False) -> None:
        """Writes DIR/experiment.toml and DIR/run<i>.csv (and DIR/static_table.csv with a static
        table, its lift column CL included, DIR/stall_polar.csv with a lift polar of its own),
        which ``indicial fit DIR/experiment.toml`` (and ``diagnose``) reads back to exactly these
        numbers. Refuses a non-empty DIR unless force=True."""
        self._e.write_files(str(directory), force)

    def toml_text(self) -> str:
        """The experiment.toml ``write_files`` writes (every key, the extensions included)."""
        return self._e.toml_text()

    def __repr__(self) -> str:
        return (f"<indicial.Experiment {self.path!r}: {self.coefficient} ({self.axis}), {len(self.runs)} runs, "
                f"V = {self.airspeed_mps} m/s>")


# --------------------------------------------------------------------------------------------
# Models and the runtime
# --------------------------------------------------------------------------------------------
class Model:
    """A coefficient file (.coef) the runtime accepts: ``Model.load(path)``, ``Model.from_text``,
    or a fit's ``result.model``. ``text`` is the file's bytes (what ``indicial fit`` writes),
    ``save(path)`` writes them. Splines are evaluated at x in rad: ``a(x_rad)``,
    ``b(x_rad, lag=1)`` (1/s at the reference airspeed), ``rotary(x_rad)``, ``static(x_rad)``."""

    def __init__(self, handle):
        self._m = handle

    @classmethod
    def load(cls, path: str) -> "Model":
        """Reads a .coef file; InputError ("FILE:LINE: problem") for a bad file or a model the
        runtime refuses, as ``indicial predict``."""
        return cls(_indicial._model_load(str(path)))

    @classmethod
    def from_text(cls, text: str, origin: str = "<text>") -> "Model":
        return cls(_indicial._model_from_text(text, origin))

    def save(self, path: str, force: bool = False) -> None:
        """Writes the coefficient file (atomically); refuses an existing file unless force=True."""
        self._m.save(str(path), force)

    text = property(lambda self: self._m.text, doc="the coefficient file's text")
    axis = property(lambda self: self._m.axis)
    coefficients = property(lambda self: list(self._m.coefficients), doc='names, e.g. ["CL", "Cm"]')
    airspeed_mps = property(lambda self: self._m.airspeed_mps, doc="V_ref, m/s")
    reference_length_m = property(lambda self: self._m.reference_length_m, doc="l, m")
    alpha0_rad = property(lambda self: self._m.alpha0_rad)
    envelope_rad = property(lambda self: (self._m.x_min_rad, self._m.x_max_rad),
                            doc="the fitted range of the model angle x, rad (outside it the runtime clamps)")
    capacity = property(lambda self: self._m.capacity,
                        doc='"default" (indicial::DefaultCapacity holds it) or "fit" (needs FitCapacity)')

    def a(self, x_rad, coefficient=None):
        return self._m.a(x_rad, coefficient)

    def b(self, x_rad, lag: int = 1, coefficient=None):
        return self._m.b(x_rad, lag, coefficient)

    def rotary(self, x_rad, coefficient=None):
        return self._m.rotary(x_rad, coefficient)

    def static(self, x_rad, coefficient=None):
        return self._m.static(x_rad, coefficient)

    def con(self, coefficient=None) -> float:
        return self._m.con(coefficient)

    def delay_s(self, coefficient=None) -> float:
        return self._m.delay_s(coefficient)

    def lags(self, coefficient=None) -> int:
        return self._m.lags(coefficient)

    def __eq__(self, other) -> bool:
        return isinstance(other, Model) and self.text == other.text

    def __repr__(self) -> str:
        return f"<indicial.Model {', '.join(self.coefficients)} ({self.axis}), V_ref = {self.airspeed_mps} m/s>"


class Predictor:
    """One instance of the runtime (runtime.hpp's Predictor): ``reset`` to the steady state,
    then ``step`` once per sample; returns {coefficient name: value}. The motion is named by
    the model's axis (alpha_rad, q_radps in pitch; phi_rad, p_radps in roll; psi_rad, r_radps
    in yaw); airspeed_mps defaults to the model's reference airspeed at reset, and at a step
    to the airspeed of the last reset or accepted step; dt_s > 0, at most 1 s. A refused step
    raises StepError and changes nothing. Usable as a context manager."""

    def __init__(self, model: Model):
        self._axis = model.axis
        self._p = _indicial._Predictor(model._m)

    def reset(self, airspeed_mps: Optional[float] = None, **motion) -> str:
        angle, _ = _motion(self._axis, motion)
        return self._p.reset(_real(angle, "angle"), airspeed_mps)

    def step(self, *, dt_s: float, airspeed_mps: Optional[float] = None, **motion) -> Dict[str, float]:
        angle, rate = _motion(self._axis, motion, need_rate=True)
        return self._p.step(_real(angle, "angle"), _real(rate, "rate"), _real(dt_s, "dt_s"), airspeed_mps)

    last_status = property(lambda self: self._p.last_status, doc='"ok" or "angle_clamped"')
    closed = property(lambda self: self._p.closed)

    def close(self) -> None:
        self._p.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class BatchStepper:
    """N instances of one model stepped together by the runtime's step_batch (SIMD lanes).

    ``reset(alpha_rad=..., airspeed_mps=None)`` and ``step(alpha_rad=..., q_radps=...,
    dt_s=..., airspeed_mps=None, out=None)`` take one number or an array of N per input
    (C-contiguous float64 arrays are read in place, never copied) and return an (N,
    n_coefficients) array: the stepper's own, overwritten by the next step (copy() it to keep
    it), or ``out``. ``run(alpha_rad=(T, N), q_radps=(T, N), dt_s=...)`` steps T samples in
    one call and returns (T, N, n_coefficients). A refused instance (NaN input, dt <= 0, ...)
    keeps its state and outputs while the others step; then StepError is raised unless
    errors="keep". ``status`` holds each instance's last status, after ``run`` its first
    refusal of the run if it had one (0 ok, 1 angle_clamped, other values:
    ``BatchStepper.status_names``); ``clamped_steps`` counts, per instance, the steps of the
    last ``step`` or ``run`` whose angle was clamped (a run's clamping that its last status
    does not show). ``airspeed_mps`` not given: the model's reference airspeed
    at ``reset``, the instance's airspeed of its last reset or accepted step at ``step`` and
    ``run``. The GIL is released while stepping."""

    status_names = _indicial._step_status_names()

    def __init__(self, model: Model, n: int):
        self._axis = model.axis
        self._s = _indicial._BatchStepper(model._m, int(n))

    def reset(self, airspeed_mps=None, errors: str = "raise", **motion) -> None:
        angle, _ = _motion(self._axis, motion)
        self._s.reset(angle, airspeed_mps, errors)

    def step(self, *, dt_s: float, airspeed_mps=None, out=None, errors: str = "raise", **motion) -> np.ndarray:
        angle, rate = _motion(self._axis, motion, need_rate=True)
        return self._s.step(angle, rate, float(dt_s), airspeed_mps, out, errors)

    def run(self, *, dt_s: float, airspeed_mps=None, out=None, errors: str = "raise", **motion) -> np.ndarray:
        angle, rate = _motion(self._axis, motion, need_rate=True)
        return self._s.run(angle, rate, float(dt_s), airspeed_mps, out, errors)

    status = property(lambda self: self._s.status)
    clamped_steps = property(lambda self: self._s.clamped_steps,
                             doc="per instance, the steps of the last step() or run() whose angle was clamped "
                                 "to the model's envelope (status angle_clamped: extrapolated, not refused); "
                                 "0 after the instance's reset")
    outputs = property(lambda self: self._s.outputs)
    coefficients = property(lambda self: list(self._s.coefficients))
    closed = property(lambda self: self._s.closed)

    def __len__(self) -> int:
        return len(self._s)

    def close(self) -> None:
        self._s.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Parameter:
    """One estimate: name as in fit.json (a1, A2, b1_0, con, y0_1, ...), value, Cramer-Rao
    bound (white residuals) and the colored-residual (sandwich) bound; bounds are NaN for a
    parameter the data cannot identify (identifiable False)."""
    name: str
    value: float
    cr_bound: float
    cr_bound_colored: float
    identifiable: bool = True


def _parameters(dicts) -> List[Parameter]:
    return [Parameter(**d) for d in dicts]


class FitResult:
    """What ``fit`` returns: ``parameters`` (list of Parameter), ``fit_error`` s(v),
    ``termination`` ("converged", "iteration_limit", "diverged", "rank_deficient"),
    ``iterations``, ``message``, ``warnings``, ``model`` (Model), ``runs`` (per run: time_s,
    x_rad, measured, model, quasi_steady, residual, ... arrays), ``covariance``,
    ``band(function, x_rad)`` (value and sigma of "a", "b1" or "rotary"), ``fit_json()``."""

    def __init__(self, handle):
        self._r = handle
        # None only for a diagnose step's intermediate fit whose model the runtime refuses.
        self.model = Model(handle.model) if handle.model is not None else None

    parameters = property(lambda self: _parameters(self._r.parameters))
    fit_error = property(lambda self: self._r.fit_error, doc="s(v) = sqrt(sum v^2 / N) of the final model")
    termination = property(lambda self: self._r.termination)
    converged = property(lambda self: self._r.termination == "converged")
    message = property(lambda self: self._r.message)
    iterations = property(lambda self: self._r.iterations)
    unidentifiable = property(lambda self: list(self._r.unidentifiable))
    elapsed_s = property(lambda self: self._r.elapsed_s, doc="wall time of the C++ fit, s")
    warnings = property(lambda self: list(self._r.warnings))
    stepwise_fallback = property(lambda self: self._r.stepwise_fallback)
    equation_error_r_squared = property(lambda self: self._r.equation_error_r_squared)
    equation_error_parameters = property(lambda self: _parameters(self._r.equation_error_parameters))
    covariance = property(lambda self: self._r.covariance)
    covariance_colored = property(lambda self: self._r.covariance_colored)
    runs = property(lambda self: self._r.runs)

    def parameter(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(f"no parameter '{name}' (the fit has {', '.join(p.name for p in self.parameters)})")

    def band(self, function: str, x_rad, kind: str = "white"):
        """(value, sigma) arrays of a(x), b1(x) or C_aq(x) at x_rad (rad), sigma from the
        white (or kind="colored") covariance: plot value +/- 2 sigma."""
        return self._r.band(function, x_rad, kind)

    def fit_json(self) -> str:
        """fit.json's fields (without provenance, warnings and plots)."""
        return self._r.fit_json()

    def __repr__(self) -> str:
        return f"<indicial.FitResult {self.termination}, s(v) = {self.fit_error:.6g}, {len(self.parameters)} parameters>"


def _fit_options(**options):
    return {k: v for k, v in options.items() if v is not None}


def fit(experiment: Experiment, *, f_to_enter: float = 4.0, f_to_remove: float = 4.0, max_iterations: int = 50,
        state_derivative: str = "smoothed", stepwise_refinement: str = "none", stepwise_significance: str = "colored",
        stepwise_fallback: str = "automatic", fallback_r_squared: float = 0.9,
        start_values: Optional[Dict[str, float]] = None, stall_start_search: str = "grid",
        stall_prior: str = "beddoes_leishman", threads: int = 2, warn: bool = True) -> FitResult:
    """Identifies the model of an experiment (``indicial fit``): equation error, stepwise
    regression, ML output error with Cramer-Rao bounds, the two-stage C_aq(x) loop. Options as
    the command line's (--f-to-enter ...; ``stall_start_search`` "grid" or "configured",
    ``stall_prior`` "beddoes_leishman" or "none": docs/formats.md). Raises InputError for bad
    input or a fitted model the runtime refuses; a diverged or rank-deficient fit is returned,
    with ``termination`` saying so. The GIL is released while fitting."""
    opts = _fit_options(f_to_enter=f_to_enter, f_to_remove=f_to_remove, max_iterations=max_iterations,
                        state_derivative=state_derivative, stepwise_refinement=stepwise_refinement,
                        stepwise_significance=stepwise_significance, stepwise_fallback=stepwise_fallback,
                        fallback_r_squared=fallback_r_squared, start_values=start_values,
                        stall_start_search=stall_start_search, stall_prior=stall_prior, threads=threads)
    r = FitResult(_indicial._fit(experiment._e, opts))
    if warn:
        _warn(r.warnings)
    return r


class Diagnosis:
    """What ``diagnose`` returns: ``steps`` (dicts: effect, detail, statistic, p_value,
    fit_error_before, fit_error_after, ..., ``rule``, the rule that decided the step, and with
    ``"leave_one_run_out"`` its evidence: held_out_rms_before / _after per run,
    held_out_mean_log_mse_ratio, held_out_standard_error; statistic and p_value then did not
    decide), ``verdict``, ``effects_added``,
    ``initial_fit_error``, ``final_fit_error``, ``noise`` (source: the replication or
    "residual_differences"; sigma and lag1_correlation: the noise, from replication where the
    data have it, else the residual's AR(1) level; residual_sigma, white_equivalent: the
    residual's levels),
    ``fits`` (FitResult per step, fits[0] the configured model), ``fit`` and ``model`` (the
    final ones), ``warnings``, ``diagnosis_json()``, ``experiment_toml()``."""

    def __init__(self, handle):
        self._d = handle
        self.fits = [FitResult(f) for f in handle.fits]
        self.fit = self.fits[-1]
        self.model = self.fit.model

    steps = property(lambda self: self._d.steps)
    verdict = property(lambda self: self._d.verdict)
    stopped = property(lambda self: self._d.stopped)
    still_significant = property(lambda self: self._d.still_significant)
    effects_added = property(lambda self: list(self._d.effects_added))
    initial_fit_error = property(lambda self: self._d.initial_fit_error)
    final_fit_error = property(lambda self: self._d.final_fit_error)
    noise = property(lambda self: self._d.noise)
    final_noise = property(lambda self: self._d.final_noise)
    ill_conditioned = property(lambda self: list(self._d.ill_conditioned))
    unconverged_models = property(lambda self: list(self._d.unconverged_models))
    elapsed_s = property(lambda self: self._d.elapsed_s)
    warnings = property(lambda self: list(self._d.warnings))

    def diagnosis_json(self) -> str:
        return self._d.diagnosis_json()

    def experiment_toml(self) -> str:
        """The experiment file of the diagnosed model (``indicial fit`` on it refits it)."""
        return self._d.experiment_toml()

    def __repr__(self) -> str:
        return (f"<indicial.Diagnosis verdict {self.verdict}: {len(self.steps)} steps, fit error "
                f"{self.initial_fit_error:.6g} -> {self.final_fit_error:.6g}>")


effect_names = _indicial._effect_names()


def diagnose(experiment: Experiment, *, alpha: float = 0.01, max_steps: int = 6, knot_spacing_deg: float = 5.0,
             knot_margin_fraction: float = 0.1, max_scan_knots: int = 16, max_family_terms: int = 4,
             indistinguishable_bic: float = 6.0, rule: str = "auto", cv_min_runs: int = 3, cv_unit: str = "run",
             max_folds: int = 10,
             min_gain: float = 0.10, min_in_sample_gain: float = 0.04, threads: int = 2, warn: bool = True,
             **fit_options) -> Diagnosis:
    """Finds where model and measurement disagree, names the missing effect (one of
    ``indicial.effect_names``), adds it and refits until nothing significant is left
    (``indicial diagnose``). Keywords are the command line's options with ``_`` for ``-``
    (docs/diagnose.md, "Options"): ``rule`` ``"auto"`` (leave-one-run-out with ``cv_min_runs``,
    3, or more runs, else likelihood ratio), ``"cv"`` or ``"lr"``; ``cv_min_runs`` (>= 2) the runs
    leave-one-run-out needs; ``cv_unit`` what a fold leaves out, ``"run"`` (default) or
    ``"group"`` (whole groups of runs: every Run needs a ``group``; docs/diagnose.md, "Groups");
    ``max_folds`` (>= 2) the folds runs (or groups) are dealt into; ``min_gain`` and ``min_in_sample_gain`` (each in [0, 1)) the cross-validation rule's
    held-out and in-sample gains, fractions of the mean square error (the held-out one with three
    folds or fewer; with K > 3 folds ``min_gain`` 3 / K); ``threads`` (>= 1) fits run
    in parallel (a scan's candidates, the held-out folds, each fit's stall start grid; the
    results do not depend on it). A bad value is an ``InputError`` (a ValueError). ``fit_options`` as ``fit``'s.
    The GIL is released meanwhile."""
    opts = dict(alpha=alpha, max_steps=max_steps, knot_spacing_deg=knot_spacing_deg,
                knot_margin_fraction=knot_margin_fraction, max_scan_knots=max_scan_knots,
                max_family_terms=max_family_terms, indistinguishable_bic=indistinguishable_bic,
                rule=rule, cv_min_runs=cv_min_runs, cv_unit=cv_unit, max_folds=max_folds, min_gain=min_gain,
                min_in_sample_gain=min_in_sample_gain, threads=threads)
    opts.update(_fit_options(**fit_options))
    d = Diagnosis(_indicial._diagnose(experiment._e, opts))
    if warn:
        _warn(d.warnings)
    return d


class Prediction:
    """What ``predict`` returns: ``time_s``, ``x_rad`` (model angle before clamping),
    ``clamped_samples``, ``scored_samples`` (the samples the metrics cover: from
    ``score_from_s`` on), and per coefficient name: ``predicted[name]`` (full model),
    ``quasi_steady[name]`` (static + rotary), ``metrics[name]`` (model and quasi-steady RMS,
    max error, Theil's inequality coefficient and the bias ``mean_error`` with ``rms_about_mean``
    and ``bias_proportion``, when measured was given), and ``warnings``
    (issued as IndicialWarning too: samples outside the model's envelope, an angle array that
    looks like degrees)."""

    def __init__(self, d: dict):
        self._d = d
        self.time_s = d["time_s"]
        self.x_rad = d["x_rad"]
        self.rate_radps = d["rate_radps"]
        self.clamped_samples = d["clamped_samples"]
        self.scored_samples = d["scored_samples"]
        c = d["coefficients"]
        self.predicted = {k: v["predicted"] for k, v in c.items()}
        self.quasi_steady = {k: v["quasi_steady"] for k, v in c.items()}
        self.metrics = {k: {"model": v["model_metrics"], "quasi_steady": v["quasi_steady_metrics"]}
                        for k, v in c.items() if "model_metrics" in v}
        self.warnings = list(d["warnings"])

    def __repr__(self) -> str:
        return f"<indicial.Prediction {', '.join(self.predicted)}: {len(self.time_s)} samples>"


def _run_arguments(model: Model, run: dict, given: dict, motion: dict) -> dict:
    """predict's arguments from a run dict (Experiment.runs, read_runs): its arrays, periodic,
    airspeed and time grid, and its measured coefficient when the model has it."""
    clash = [k for k, v in given.items() if v is not None] + sorted(motion)
    if clash:
        raise TypeError(f"predict: run= gives the motion, time and measurement; not also {', '.join(clash)}")
    missing = [k for k in ("time_s", "motion_angle_rad") if k not in run]
    if missing:
        raise InputError(f"predict: run= is missing {', '.join(missing)} (a run of Experiment.runs or read_runs)")
    axis = run.get("axis")
    if axis is not None and axis != model.axis:   # as `predict --experiment E --run N` refuses it
        raise InputError(f"predict: run= is a {axis} run; the model is {model.axis}")
    measured = None
    name = run.get("coefficient_name")
    if name is not None and run.get("coefficient") is not None:
        if name in model.coefficients:
            measured = {name: run["coefficient"]}
        else:
            _warn([f"predict: the run measures {name}, which the model does not have "
                   f"({', '.join(model.coefficients)}): predicted, not scored"])
    return dict(time_s=run["time_s"], angle=run["motion_angle_rad"], rate=run.get("rate_radps"),
                periodic=bool(run.get("periodic", False)), airspeed_mps=run.get("airspeed_mps"),
                time_grid=run.get("time_grid", "uniform"), measured=measured)


def predict(model: Model, *, time_s=None, airspeed_mps: Optional[float] = None, periodic: Optional[bool] = None,
            measured: Optional[Dict[str, Sequence[float]]] = None, time_grid: Optional[str] = None,
            score_from_s: float = -math.inf, run: Optional[dict] = None, **motion) -> Prediction:
    """Runs the runtime over a sampled motion (``indicial predict``): from the steady state at
    the first sample, or, with periodic=True, the periodic steady state of one cycle
    (``--periodic``). The motion by the model's axis' names (alpha_rad and optional q_radps in
    pitch, ...); without a rate, the Savitzky-Golay derivative of the angle. ``measured``:
    {name: array} to score; ``score_from_s``: score only the samples at time_s >= it
    (``--score-from-s``: a raw log's start-up transient left out; every sample is still
    predicted). ``periodic=True`` needs one whole cycle (refused otherwise, as ``--periodic``).
    The command line's warnings are issued as IndicialWarning. The GIL is released while
    stepping.

    ``run=r``, one of ``Experiment.runs`` or ``read_runs``' run dicts, gives the time, motion,
    periodic, airspeed and time grid, and scores its measured coefficient when the model has it
    (``indicial predict --experiment E --run N``); then none of those is given apart."""
    if run is not None:
        a = _run_arguments(model, run, dict(time_s=time_s, airspeed_mps=airspeed_mps, periodic=periodic,
                                             measured=measured, time_grid=time_grid), motion)
        time_s, angle, rate = a["time_s"], a["angle"], a["rate"]
        airspeed_mps, periodic, measured, time_grid = a["airspeed_mps"], a["periodic"], a["measured"], a["time_grid"]
    else:
        if time_s is None:
            raise TypeError("predict: time_s (or run=) is required")
        angle, rate = _motion(model.axis, motion)
    p = Prediction(_indicial._predict(model._m, time_s, angle, rate, airspeed_mps, bool(periodic), measured,
                                      time_grid or "uniform", _real(score_from_s, "score_from_s")))
    _warn(p.warnings)
    return p


def read_runs(path: str) -> Dict[str, list]:
    """The runs an experiment file names, read exactly as ``indicial fit`` reads them (one file
    or ``files = [...]`` at their own phases, resampled; [columns] and each file's own map;
    Cnormal/Ctangential; phase columns), without its [static], [rotary] or [model] (not
    needed): {coefficient: [run dict]}, each run dict with ``time_s``, ``motion_angle_rad``,
    ``rate_radps``, ``coefficient`` (the measured values of ``coefficient_name``),
    ``periodic``, ``airspeed_mps``, ``time_grid``, ``frequency_hz``, ``axis``, ``name``,
    ``warnings`` (issued as IndicialWarning too). A held-out digitized cycle so reaches
    ``predict``: ``predict(model, run=read_runs("held.toml")["CL"][0])`` (``indicial predict
    --experiment held.toml --run 1``), predicted and scored."""
    out = {name: [dict(r, coefficient_name=name) for r in runs]
           for name, runs in _indicial._read_runs(str(path)).items()}
    # Each coefficient reads the same files: a file's warning once.
    warnings = [w for runs in out.values() for r in runs for w in r["warnings"]]
    _warn(list(dict.fromkeys(warnings)))
    return out


class QuasiStaticPolar:
    """What ``quasi_static_polar`` returns: ``x_rad`` (each row's mean model angle, rad),
    ``values`` ({coefficient: array}, the bin means), ``samples`` (per row; 0 for a held row),
    ``bins_dropped``, ``samples_used``, ``runs``, ``held_rows``, ``axis``, and ``csv`` (the
    static-table CSV ``indicial polar`` writes: ``write(path)`` writes it)."""

    def __init__(self, d: dict):
        self.x_rad = d["x_rad"]
        self.values = dict(d["values"])
        self.samples = d["samples"]
        self.bins_dropped = d["bins_dropped"]
        self.samples_used = d["samples_used"]
        self.runs = d["runs"]
        self.held_rows = d["held_rows"]
        self.axis = d["axis"]
        self.csv = d["csv"]
        self._inputs = list(d["inputs"])

    def write(self, path: str, force: bool = False) -> None:
        """Writes ``csv`` to path, atomically; refuses an existing file unless force=True, and
        the experiment file or a run file it was made from always."""
        _indicial._write_polar(str(path), self.csv, bool(force), self._inputs)

    def __repr__(self) -> str:
        return f"<indicial.QuasiStaticPolar {', '.join(self.values)}: {len(self.x_rad)} rows>"


def quasi_static_polar(path: str, *, bin_deg: float = 1.0, min_samples: int = 4, stroke: str = "outward",
                       hold_deg: float = 0.0) -> QuasiStaticPolar:
    """A static table from the quasi-static cycles an experiment file names (``indicial
    polar``; the file needs no [static]): the outward samples (the angle moving away from zero;
    ``stroke="rising"``: the angle increasing, ``"both"``: all) in
    ``bin_deg`` bins centred on multiples of it, a row per bin of >= ``min_samples`` samples at
    its mean angle; ``hold_deg``: one more row that far beyond each end, holding the end values.
    Warnings of the reader are issued as IndicialWarning."""
    d = _indicial._quasi_static_polar(str(path), _real(bin_deg, "bin_deg"), int(min_samples), str(stroke),
                                      _real(hold_deg, "hold_deg"))
    _warn(d["warnings"])
    return QuasiStaticPolar(d)


@dataclass
class SimulatedRun:
    """A simulated run: time_s, motion_angle_rad, rate_radps (exact), x_rad, and per
    coefficient name: measured (true + noise), true, y_true (the unsteady part)."""
    time_s: np.ndarray
    motion_angle_rad: np.ndarray
    rate_radps: np.ndarray
    x_rad: np.ndarray
    measured: Dict[str, np.ndarray]
    true: Dict[str, np.ndarray]
    y_true: Dict[str, np.ndarray]
    sigma: Optional[np.ndarray] = None
    name: str = ""


def _simulated(d: dict) -> SimulatedRun:
    return SimulatedRun(d["time_s"], d["motion_angle_rad"], d["rate_radps"], d["x_rad"], d["measured"], d["true"],
                        d["y_true"], d.get("sigma"), d.get("name", ""))


def simulate(model: Model, *, motion: Optional[str] = None, time_s=None, snr: float = math.inf, seed: int = 1,
             noise: str = "white", airspeed_mps: Optional[float] = None, **angle) -> SimulatedRun:
    """Simulates a model with the accurate reference integration (Dormand-Prince 5(4),
    tolerance 1e-12; ``indicial simulate --model``), from rest. The motion is a spec string
    ("sine:alpha0_deg=35,amp_deg=35,freq_hz=0.5,cycles=3,dt_s=0.01", "ramp:...") or sampled
    arrays (time_s and alpha_rad / phi_rad / psi_rad, uniform). Noise: sigma = RMS(y) / snr,
    "white", "ar1:phi=0.8" or "turbulence:cutoff_hz=2"."""
    samples = None
    if motion is None:
        samples, _ = _motion(model.axis, angle)
    elif time_s is not None or any(v is not None for v in angle.values()):
        raise InputError("simulate: give motion= or time_s with the angle, not both")
    snr_arg = "inf" if math.isinf(snr) else float(snr)
    return _simulated(_indicial._simulate(model._m, motion, time_s, samples, snr_arg, int(seed), noise,
                                          airspeed_mps))


@dataclass
class SimulationCase:
    """A built-in simulated case (``indicial simulate --case``): the truth Model, the
    simulated runs (SimulatedRun), the noise sigma per coefficient and the case's experiment
    configuration (TOML text, runs without data)."""
    name: str
    description: str
    truth: Model
    runs: List[SimulatedRun]
    sigma: np.ndarray
    experiment_toml: str


simulation_case_names = _indicial._simulation_case_names()


def simulation_case(name: str, *, snr: float = math.inf, seed: int = 1, noise: str = "white") -> SimulationCase:
    """Simulates a built-in case (``indicial.simulation_case_names``: tailless-model-1 and -2 are
    the report's Example 1) in memory, with the same noise stream as ``indicial simulate --case``."""
    snr_arg = "inf" if math.isinf(snr) else float(snr)
    d = _indicial._simulation_case(name, snr_arg, int(seed), noise)
    return SimulationCase(d["name"], d["description"], Model(d["truth"]), [_simulated(r) for r in d["runs"]],
                          d["sigma"], d["experiment_toml"])
