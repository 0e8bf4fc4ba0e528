// python/src/stepper_binding.cpp -- the runtime from Python: indicial.Predictor (one
// instance, runtime.hpp's Predictor) and indicial.BatchStepper (N instances of one model,
// batch.hpp's step_batch on the caller's numpy memory).
//
// What it is for
// --------------
// A simulator prototype or a Monte Carlo in a notebook steps the SAME runtime a simulator
// embeds: same validation at load, same clamping, same statuses. The batch stepper keeps one
// RuntimeModel and N states in C++; each call passes the angle, rate and airspeed of every
// instance (an array of N, or one number for all) and gets an (N, n_coefficients) array.
//
// Warnings
// --------
// 1. No copies: a C-contiguous float64 input is read in place, and the outputs are written
//    into the stepper's own array (returned; overwritten by the next step: copy() to keep) or
//    into `out` (must be a writable C-contiguous float64 array of the right shape; never
//    converted, since writes into a converted copy would be lost). Other dtypes and strided
//    inputs are converted (a copy).
// 2. The runtime refuses an instance's step on bad input (NaN, dt <= 0, airspeed <= 0): that
//    instance keeps its state and its output row, the others step. The call then raises
//    indicial.StepError naming the first refused instance and its status (errors="raise",
//    the default) or returns normally (errors="keep"); `status` holds every instance's.
// 3. The GIL is released while stepping; a stepper used by two threads at once raises
//    indicial.StepError (it is not locked, it is refused). close() frees the states; any
//    later use raises indicial.ClosedError.
// 4. Capacity: a model the default runtime capacity holds is stepped with DefaultCapacity
//    (the C++ benchmarks' configuration), a larger one with FitCapacity. A model with a
//    delay is stepped with DelayedStates (step_batch's one-instance-at-a-time overload), one
//    with dynamic-stall families with FamilyStates.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <memory>

#include "bindings.hpp"

#include "indicial/batch.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial::python {
namespace {

bool stepped(StepStatus s) { return s == StepStatus::ok || s == StepStatus::angle_clamped; }

// The runtime's model and N states, behind one interface for the four (capacity, state)
// combinations.
struct BatchCore {
  virtual ~BatchCore() = default;
  virtual StepStatus reset(std::size_t i, double angle_rad, double airspeed_mps) = 0;
  // Instance i's outputs at its last sample, at rest (rate 0), without stepping it.
  virtual StepStatus evaluate(std::size_t i, double airspeed_mps, double* out) const = 0;
  virtual StepStatus step(const double* angle, const double* rate, const double* airspeed, double dt_s, double* out,
                          StepStatus* status) = 0;
  std::size_t n = 0;
  int n_out = 0;
};

template <class Cap, class StateT>
struct BatchCoreOf final : BatchCore {
  std::unique_ptr<RuntimeModel<double, Cap>> model = std::make_unique<RuntimeModel<double, Cap>>();
  std::vector<StateT> states;
  StepStatus reset(std::size_t i, double angle_rad, double airspeed_mps) override {
    return indicial::reset(*model, states[i], angle_rad, airspeed_mps);
  }
  StepStatus evaluate(std::size_t i, double airspeed_mps, double* out) const override {
    return indicial::evaluate(*model, states[i], 0.0, airspeed_mps, out);
  }
  StepStatus step(const double* angle, const double* rate, const double* airspeed, double dt_s, double* out,
                  StepStatus* status) override {
    return step_batch(*model, states.data(), n, angle, rate, airspeed, dt_s, out, status);
  }
};

template <class Cap, class StateT>
std::unique_ptr<BatchCore> make_core(const ModelHolder& h, std::size_t n) {
  auto core = std::make_unique<BatchCoreOf<Cap, StateT>>();
  ParseDiagnostic diag;
  const LoadStatus s = load_runtime_model(h.text.data(), h.text.size(), core->model.get(), &diag);
  if (s != LoadStatus::ok)
    throw InputError(h.origin, static_cast<long>(diag.line),
                     "the runtime refuses the model: " + std::string(diag.reason) + " (" + to_string(s) + ")");
  core->states.resize(n);
  core->n = n;
  core->n_out = core->model->set.n_coefficients;
  return core;
}

// The state type step_batch needs for the model: a delay history (stepped one instance at a
// time), the dynamic-stall families' states, or the plain lag states.
template <class Cap>
std::unique_ptr<BatchCore> make_core_for(const ModelHolder& h, std::size_t n, bool delayed, bool families) {
  if (delayed) return make_core<Cap, DelayedState<double, Cap>>(h, n);
  if (families) return make_core<Cap, FamilyState<double, Cap>>(h, n);
  return make_core<Cap, State<double, Cap>>(h, n);
}

// Marks a stepper busy for the duration of a call (warning 3).
class Busy {
 public:
  explicit Busy(std::atomic<bool>& flag) : flag_(flag) {
    if (flag_.exchange(true)) throw StepError("this stepper is being stepped by another thread");
  }
  ~Busy() { flag_.store(false); }
  Busy(const Busy&) = delete;
  Busy& operator=(const Busy&) = delete;

 private:
  std::atomic<bool>& flag_;
};

class BatchStepper {
 public:
  BatchStepper(const ModelPtr& model, std::size_t n) : model_(model) {
    if (!model) throw ClosedError("BatchStepper: no model");
    if (n == 0) throw InputError("BatchStepper", 0, "needs at least one instance (n >= 1)");
    bool delayed = false, families = false;
    for (int c = 0; c < model->set->n_coefficients; ++c) {
      delayed = delayed || model->set->coefficients[c].delay_s != 0.0;
      families = families || model->set->coefficients[c].stall.families != StallFamilies::none;
    }
    if (model->acceptance.capacity == RuntimeCapacity::default_capacity)
      core_ = make_core_for<DefaultCapacity>(*model, n, delayed, families);
    else
      core_ = make_core_for<FitCapacity>(*model, n, delayed, families);
    status_.assign(n, StepStatus::not_reset);
    clamped_.assign(n, 0);
    airspeed_.assign(n, model->set->airspeed_mps);
    outputs_ = py::array_t<double>({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(core_->n_out)});
    std::fill(outputs_.mutable_data(), outputs_.mutable_data() + outputs_.size(), 0.0);
  }

  std::size_t size() const { return core().n; }

  void reset(const py::handle& angle, const py::handle& airspeed, const std::string& errors) {
    Busy busy(busy_);
    check_errors_value(errors);  // before anything changes
    const Inputs a = inputs(angle_slot, angle, "angle_rad");
    // Not given: the model's reference airspeed, as Predictor.reset (a step's default is the
    // last reset's or step's airspeed, airspeed_inputs).
    const Inputs v = airspeed.is_none() ? constant(airspeed_slot, model_->set->airspeed_mps)
                                        : inputs(airspeed_slot, airspeed, "airspeed_mps");
    // An instance reset writes its outputs at rest (they read 0 until the first step); a
    // refused one keeps its state and outputs.
    double* o = outputs_.mutable_data();
    const auto row = static_cast<std::size_t>(core().n_out);
    for (std::size_t i = 0; i < core().n; ++i) {
      status_[i] = core_->reset(i, a.at(i), v.at(i));
      if (stepped(status_[i])) {
        core_->evaluate(i, v.at(i), o + i * row);
        airspeed_[i] = v.at(i);
        clamped_[i] = 0;  // a reset instance has stepped nothing since
      }
    }
    raise_first_refusal(errors, "reset");
  }

  py::array_t<double> step(const py::handle& angle, const py::handle& rate, double dt_s, const py::handle& airspeed,
                           const py::object& out, const std::string& errors) {
    Busy busy(busy_);
    check_errors_value(errors);  // before anything changes
    const Inputs a = inputs(angle_slot, angle, "angle_rad");
    const Inputs r = inputs(rate_slot, rate, "rate_radps");
    const Inputs v = airspeed_inputs(airspeed);
    py::array_t<double> target = out.is_none() ? outputs_ : checked_out(out, {core().n}, core().n_out);
    double* o = target.mutable_data();
    StepStatus first = StepStatus::ok;
    {
      py::gil_scoped_release release;
      first = core_->step(a.data, r.data, v.data, dt_s, o, status_.data());
      std::fill(clamped_.begin(), clamped_.end(), 0);
      count_clamped(first);
    }
    keep_airspeeds(v);
    if (!stepped(first)) raise_first_refusal(errors, "step");  // step_batch returns the first refusal
    return target;
  }

  // T steps of every instance: angle and rate of shape (T, N) (or (T,) for all instances),
  // outputs (T, N, n_coefficients): one call, one GIL release, for a whole history.
  py::array_t<double> run(const py::handle& angle, const py::handle& rate, double dt_s, const py::handle& airspeed,
                          const py::object& out, const std::string& errors) {
    Busy busy(busy_);
    check_errors_value(errors);  // before anything changes
    const DoubleArray a = as_doubles(angle, "angle_rad"), r = as_doubles(rate, "rate_radps");
    const std::size_t n = core().n;
    if (a.ndim() != 2 || r.ndim() != 2 || a.shape(1) != static_cast<py::ssize_t>(n) ||
        r.shape(0) != a.shape(0) || r.shape(1) != a.shape(1))
      throw InputError("run", 0, "angle_rad and rate_radps must both have shape (T, " + std::to_string(n) + ")");
    const std::size_t t_count = static_cast<std::size_t>(a.shape(0));
    const Inputs v = airspeed_inputs(airspeed);
    py::array_t<double> target;
    if (out.is_none())
      target = py::array_t<double>({static_cast<py::ssize_t>(t_count), static_cast<py::ssize_t>(n),
                                    static_cast<py::ssize_t>(core().n_out)});
    else
      target = checked_out(out, {t_count, n}, core().n_out);
    double* o = target.mutable_data();
    const double* ap = a.data();
    const double* rp = r.data();
    // Each instance's first refusal in the run (its time step and status): what `status` holds
    // for it afterwards, and what the StepError names. A refusal at any time step counts, not
    // only at the last (the statuses of the last step alone hid a NaN at an earlier row).
    std::vector<std::size_t> refused_at(n, t_count);
    std::vector<StepStatus> refusal(n, StepStatus::ok);
    {
      py::gil_scoped_release release;
      const std::size_t row = n * static_cast<std::size_t>(core_->n_out);
      const std::size_t n_out = static_cast<std::size_t>(core_->n_out);
      std::fill(clamped_.begin(), clamped_.end(), 0);
      for (std::size_t k = 0; k < t_count; ++k) {
        const StepStatus s = core_->step(ap + k * n, rp + k * n, v.data, dt_s, o + k * row, status_.data());
        count_clamped(s);
        if (stepped(s)) continue;
        // A refused instance keeps its outputs: its row repeats the previous step's.
        const double* before = k > 0 ? o + (k - 1) * row : outputs_.data();
        for (std::size_t i = 0; i < n; ++i) {
          if (stepped(status_[i])) continue;
          std::copy(before + i * n_out, before + (i + 1) * n_out, o + k * row + i * n_out);
          if (refused_at[i] == t_count) {
            refused_at[i] = k;
            refusal[i] = status_[i];
          }
        }
      }
      std::copy(o + (t_count - 1) * row, o + t_count * row, outputs_.mutable_data());
    }
    keep_airspeeds(v);  // by each instance's last step, before the statuses become the first refusals
    for (std::size_t i = 0; i < n; ++i)
      if (refused_at[i] < t_count) status_[i] = refusal[i];
    // The first refusal in time (the lowest instance among those refused at that step).
    const std::size_t first = static_cast<std::size_t>(
        std::min_element(refused_at.begin(), refused_at.end()) - refused_at.begin());
    if (refused_at[first] < t_count && errors == "raise") {
      std::size_t more = 0;
      for (std::size_t i = 0; i < n; ++i) more += (i != first && refused_at[i] < t_count) ? 1 : 0;
      throw StepError("run (time step " + std::to_string(refused_at[first]) + " first refused): the runtime refused "
                      "instance " + std::to_string(first) + " (" + to_string(refusal[first]) + ")" +
                      (more > 0 ? " and " + std::to_string(more) + " more" : std::string()) +
                      "; refused instances keep their state and outputs, the others stepped (see .status)");
    }
    return target;
  }

  // Per instance, the steps of the last step() or run() call its angle was clamped in (status
  // angle_clamped: outputs produced, the unsteady terms held at the envelope's edge); 0 after
  // the instance's reset.
  py::array_t<std::int64_t> clamped_steps() const {
    py::array_t<std::int64_t> c(static_cast<py::ssize_t>(clamped_.size()));
    std::copy(clamped_.begin(), clamped_.end(), c.mutable_data());
    return c;
  }

  py::array_t<int> status() const {
    py::array_t<int> s(static_cast<py::ssize_t>(status_.size()));
    for (std::size_t i = 0; i < status_.size(); ++i) s.mutable_data()[i] = static_cast<int>(status_[i]);
    return s;
  }
  py::array_t<double> outputs() const { return outputs_; }
  std::vector<std::string> coefficients() const {
    std::vector<std::string> names;
    for (int c = 0; c < model_->set->n_coefficients; ++c) names.emplace_back(model_->set->coefficients[c].name);
    return names;
  }
  void close() {
    Busy busy(busy_);
    core_.reset();
  }
  bool closed() const { return !core_; }

 private:
  // One input for every instance: the caller's array in place, or a number repeated.
  struct Inputs {
    DoubleArray keep;  // holds the array (the caller's, or a conversion) alive
    const double* data = nullptr;
    bool scalar = false;
    double at(std::size_t i) const { return scalar ? data[0] : data[i]; }
  };
  // Which input a number is repeated for: each has its own buffer (refilled only when the
  // number changes), so that the angle and the airspeed never share one.
  enum Slot { angle_slot = 0, rate_slot = 1, airspeed_slot = 2 };
  Inputs constant(Slot slot, double value) {
    Fill& f = fill_[slot];
    if (f.values.size() != core().n || !f.filled || !(f.value == value)) {
      f.values.assign(core().n, value);
      f.value = value;
      f.filled = true;
    }
    Inputs in;
    in.data = f.values.data();
    return in;
  }
  Inputs inputs(Slot slot, const py::handle& value, const char* name) {
    if (PyFloat_Check(value.ptr()) || PyLong_Check(value.ptr())) return constant(slot, value.cast<double>());
    Inputs in;
    // The common case first, with no conversion call at all: the caller's C-contiguous float64
    // array of one value per instance, read in place.
    if (py::isinstance<DoubleArray>(value)) {
      auto a = py::reinterpret_borrow<DoubleArray>(value);
      if (a.ndim() == 1 && a.shape(0) == static_cast<py::ssize_t>(core().n)) {
        in.keep = std::move(a);
        in.data = in.keep.data();
        return in;
      }
    }
    in.keep = as_doubles(value, name);
    if (in.keep.ndim() == 0) return constant(slot, *in.keep.data());
    if (in.keep.ndim() != 1 || in.keep.shape(0) != static_cast<py::ssize_t>(core().n))
      throw InputError(name, 0, "expected one number or an array of " + std::to_string(core().n) +
                                    " (one per instance), got shape " + shape_text(in.keep));
    in.data = in.keep.data();
    return in;
  }
  // Not given: each instance's airspeed of its last reset or accepted step (the model's
  // reference airspeed before any), never silently the reference airspeed after a reset at
  // another one (a trial's reset at 20 m/s stepped at 17.7 m/s, 0.03 off in C_L).
  Inputs airspeed_inputs(const py::handle& airspeed) {
    if (!airspeed.is_none()) return inputs(airspeed_slot, airspeed, "airspeed_mps");
    Inputs in;
    in.data = airspeed_.data();
    return in;
  }
  // After a step or run: the airspeed each accepted instance stepped at becomes its default.
  void keep_airspeeds(const Inputs& v) {
    if (v.data == airspeed_.data()) return;
    for (std::size_t i = 0; i < airspeed_.size(); ++i)
      if (stepped(status_[i])) airspeed_[i] = v.at(i);
  }
  static std::string shape_text(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
    return s + (a.ndim() == 1 ? ",)" : ")");
  }
  py::array_t<double> checked_out(const py::object& out, std::vector<std::size_t> lead, int n_out) const {
    if (!py::isinstance<py::array_t<double>>(out))
      throw py::type_error("out: expected a float64 numpy array");
    py::array arr = out.cast<py::array>();
    lead.push_back(static_cast<std::size_t>(n_out));
    bool ok = arr.dtype().is(py::dtype::of<double>()) && arr.writeable() &&
              (arr.flags() & py::array::c_style) && arr.ndim() == static_cast<py::ssize_t>(lead.size());
    for (std::size_t d = 0; ok && d < lead.size(); ++d) ok = arr.shape(static_cast<py::ssize_t>(d)) == static_cast<py::ssize_t>(lead[d]);
    if (!ok) {
      std::string want = "(";
      for (std::size_t d = 0; d < lead.size(); ++d) want += (d ? ", " : "") + std::to_string(lead[d]);
      throw InputError("out", 0, "expected a writable C-contiguous float64 array of shape " + want + "), got " +
                                     shape_text(arr) + " " + std::string(py::str(arr.dtype())));
    }
    return py::reinterpret_borrow<py::array_t<double>>(arr);
  }
  static void check_errors_value(const std::string& errors) {
    if (errors != "raise" && errors != "keep") throw InputError("errors", 0, "expected 'raise' or 'keep'");
  }
  // step_batch returns ok only when no instance was clamped or refused: the per-instance
  // statuses are read only otherwise.
  void count_clamped(StepStatus batch) {
    if (batch == StepStatus::ok) return;
    for (std::size_t i = 0; i < status_.size(); ++i)
      if (status_[i] == StepStatus::angle_clamped) ++clamped_[i];
  }

  void raise_first_refusal(const std::string& errors, const std::string& what) const {
    if (errors == "keep") return;
    std::size_t refused = 0, first = status_.size();
    for (std::size_t i = 0; i < status_.size(); ++i)
      if (!stepped(status_[i])) {
        ++refused;
        if (first == status_.size()) first = i;
      }
    if (refused == 0) return;
    throw StepError(what + ": the runtime refused instance " + std::to_string(first) + " (" +
                    to_string(status_[first]) + ")" +
                    (refused > 1 ? " and " + std::to_string(refused - 1) + " more" : std::string()) +
                    "; refused instances keep their state and outputs, the others stepped (see .status)");
  }
  BatchCore& core() const {
    if (!core_) throw ClosedError("this BatchStepper is closed");
    return *core_;
  }

  ModelPtr model_;
  std::unique_ptr<BatchCore> core_;
  std::vector<StepStatus> status_;
  std::vector<std::int64_t> clamped_;  // clamped_steps(): per instance, of the last step or run
  std::vector<double> airspeed_;  // per instance: the default airspeed (airspeed_inputs)
  py::array_t<double> outputs_;
  struct Fill {
    std::vector<double> values;
    double value = 0.0;
    bool filled = false;
  };
  Fill fill_[3];
  std::atomic<bool> busy_{false};
};

// One instance: runtime.hpp's Predictor at FitCapacity (every model the fitter writes).
class SinglePredictor {
 public:
  explicit SinglePredictor(const ModelPtr& model) : model_(model) {
    if (!model) throw ClosedError("Predictor: no model");
    p_ = std::make_unique<Predictor<double, FitCapacity>>();
    airspeed_mps_ = model->set->airspeed_mps;
    ParseDiagnostic diag;
    const LoadStatus s = p_->load(*model->set, &diag);
    if (s != LoadStatus::ok)
      throw InputError(model->origin, 0, "the runtime refuses the model: " + std::string(diag.reason) + " (" +
                                             to_string(s) + ")");
  }
  std::string reset(double angle_rad, const py::object& airspeed) {
    Busy busy(busy_);
    const double v = airspeed.is_none() ? model_->set->airspeed_mps : airspeed.cast<double>();
    const std::string status = checked(pred().reset(angle_rad, v), "reset");
    airspeed_mps_ = v;
    return status;
  }
  py::dict step(double angle_rad, double rate_radps, double dt_s, const py::object& airspeed) {
    Busy busy(busy_);
    // Not given: the airspeed of the last reset or accepted step (see BatchStepper).
    const double v = airspeed.is_none() ? airspeed_mps_ : airspeed.cast<double>();
    Predictor<double, FitCapacity>::Outputs out;
    last_ = checked(pred().step(MotionInput{angle_rad, rate_radps, v}, dt_s, &out), "step");
    airspeed_mps_ = v;
    py::dict d;
    for (int c = 0; c < out.count; ++c) d[py::str(out.name[c])] = out.value[c];
    return d;
  }
  const std::string& last_status() const { return last_; }
  void close() {
    Busy busy(busy_);
    p_.reset();
  }
  bool closed() const { return !p_; }

 private:
  Predictor<double, FitCapacity>& pred() {
    if (!p_) throw ClosedError("this Predictor is closed");
    return *p_;
  }
  static std::string checked(StepStatus s, const char* what) {
    if (!stepped(s))
      throw StepError(std::string(what) + " refused by the runtime: " + to_string(s) + " (the state is unchanged)");
    return to_string(s);
  }
  ModelPtr model_;
  std::unique_ptr<Predictor<double, FitCapacity>> p_;
  std::string last_ = "not_reset";
  double airspeed_mps_ = 0.0;  // the default airspeed of step (the last reset's or accepted step's)
  std::atomic<bool> busy_{false};
};

}  // namespace

void bind_stepper(py::module_& m) {
  py::class_<SinglePredictor>(m, "_Predictor")
      .def(py::init<const ModelPtr&>(), py::arg("model"))
      .def("reset", &SinglePredictor::reset, py::arg("angle_rad"), py::arg("airspeed_mps") = py::none())
      .def("step", &SinglePredictor::step, py::arg("angle_rad"), py::arg("rate_radps"), py::arg("dt_s"),
           py::arg("airspeed_mps") = py::none())
      .def_property_readonly("last_status", &SinglePredictor::last_status)
      .def_property_readonly("closed", &SinglePredictor::closed)
      .def("close", &SinglePredictor::close);
  py::class_<BatchStepper>(m, "_BatchStepper")
      .def(py::init<const ModelPtr&, std::size_t>(), py::arg("model"), py::arg("n"))
      .def("reset", &BatchStepper::reset, py::arg("angle_rad"), py::arg("airspeed_mps") = py::none(),
           py::arg("errors") = "raise")
      .def("step", &BatchStepper::step, py::arg("angle_rad"), py::arg("rate_radps"),
           py::arg("dt_s"), py::arg("airspeed_mps") = py::none(), py::arg("out") = py::none(),
           py::arg("errors") = "raise")
      .def("run", &BatchStepper::run, py::arg("angle_rad"), py::arg("rate_radps"),
           py::arg("dt_s"), py::arg("airspeed_mps") = py::none(), py::arg("out") = py::none(),
           py::arg("errors") = "raise")
      .def_property_readonly("status", &BatchStepper::status)
      .def_property_readonly("clamped_steps", &BatchStepper::clamped_steps)
      .def_property_readonly("outputs", &BatchStepper::outputs)
      .def_property_readonly("coefficients", &BatchStepper::coefficients)
      .def_property_readonly("closed", &BatchStepper::closed)
      .def("__len__", &BatchStepper::size)
      .def("close", &BatchStepper::close);
  m.def("_step_status_names", [] {
    std::vector<std::string> names;
    for (int s = 0; s <= static_cast<int>(StepStatus::delay_needs_history); ++s)
      names.emplace_back(to_string(static_cast<StepStatus>(s)));
    return names;
  });
}

}  // namespace indicial::python
