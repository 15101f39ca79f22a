// Conversions between Python values and ctr types, and the translation of ctr exceptions.
#include <algorithm>
#include <cmath>

#include "common.hpp"
#include "ctr/io/input_error.hpp"

namespace ctr::py {

Workspace& workspace() {
  thread_local Workspace ws;
  return ws;
}

Eigen::VectorXd toVector(const pyb::handle& obj, const std::string& what) {
  pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast> a;
  try {
    a = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>::ensure(obj);
  } catch (const pyb::error_already_set&) {
  }
  if (!a || a.ndim() > 1)
    throw pyb::value_error(what + ": expected a sequence of numbers, got " + pyb::repr(obj).cast<std::string>());
  Eigen::VectorXd v(a.size());
  for (pyb::ssize_t k = 0; k < a.size(); ++k) v[k] = a.data()[k];
  return v;
}

Eigen::MatrixXd toMatrix(const pyb::handle& obj, const std::string& what, int cols) {
  pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast> a;
  try {
    a = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>::ensure(obj);
  } catch (const pyb::error_already_set&) {
  }
  if (!a || a.ndim() > 2)
    throw pyb::value_error(what + ": expected a 2-D array of numbers, got " + pyb::repr(obj).cast<std::string>());
  const pyb::ssize_t rows = a.ndim() == 2 ? a.shape(0) : 1;
  const pyb::ssize_t c = a.ndim() == 2 ? a.shape(1) : a.size();
  if (c != cols)
    throw pyb::value_error(what + ": expected " + std::to_string(cols) + " columns, got " + std::to_string(c));
  Eigen::MatrixXd out(rows, cols);
  for (pyb::ssize_t r = 0; r < rows; ++r)
    for (pyb::ssize_t k = 0; k < cols; ++k) out(r, k) = a.data()[r * cols + k];
  return out;
}

Configuration toConfiguration(const Robot& robot, const pyb::handle& alpha, const pyb::handle& beta, int swept_tube,
                              double swept_angle) {
  const int n = robot.size();
  Configuration q = defaultConfiguration(robot);
  auto take = [&](const pyb::handle& obj, const char* name, Eigen::VectorXd& dst) {
    if (obj.is_none()) return;
    Eigen::VectorXd v = toVector(obj, name);
    if (v.size() != n)
      throw pyb::value_error(std::string(name) + ": " + std::to_string(v.size()) + " values given, robot '" +
                             robot.name() + "' has " + std::to_string(n) + " tubes");
    for (int i = 0; i < n; ++i)
      if (!std::isfinite(v[i]))
        throw pyb::value_error(std::string(name) + ": item " + std::to_string(i + 1) + " is not a finite number");
    dst = v;
  };
  take(alpha, "alpha", q.alpha);
  take(beta, "beta", q.beta);
  if (swept_tube >= 0 && swept_tube < n) q.alpha[swept_tube] = swept_angle;
  const Admissibility adm = projectAdmissible(robot, q);
  if (!adm) {
    const bool rotation = adm.actuator == Admissibility::Actuator::Rotation;
    throw pyb::value_error(std::string(rotation ? "alpha" : "beta") +
                           ": configuration is not admissible: " + adm.message);
  }
  return q;
}

pyb::tuple configurationTuple(const Configuration& q) {
  return pyb::make_tuple(pyb::array_t<double>(q.alpha.size(), q.alpha.data()),
                         pyb::array_t<double>(q.beta.size(), q.beta.data()));
}

pyb::tuple configurationArrays(const std::vector<Configuration>& qs, int n) {
  const auto rows = static_cast<pyb::ssize_t>(qs.size());
  pyb::array_t<double> a({rows, static_cast<pyb::ssize_t>(n)}), b({rows, static_cast<pyb::ssize_t>(n)});
  auto av = a.mutable_unchecked<2>();
  auto bv = b.mutable_unchecked<2>();
  for (pyb::ssize_t r = 0; r < rows; ++r)
    for (int i = 0; i < n; ++i) {
      const Configuration& q = qs[static_cast<std::size_t>(r)];
      av(r, i) = i < q.alpha.size() ? q.alpha[i] : NAN;
      bv(r, i) = i < q.beta.size() ? q.beta[i] : NAN;
    }
  return pyb::make_tuple(a, b);
}

pyb::array_t<double> array3(const Eigen::Vector3d& v) {
  return pyb::array_t<double>(3, v.data());
}

void setAttributes(pyb::object self, const pyb::kwargs& kwargs) {
  for (const auto& item : kwargs) {
    const std::string key = pyb::str(item.first).cast<std::string>();
    if (!pyb::hasattr(self, key.c_str()))
      throw pyb::type_error(pyb::str(self.get_type().attr("__name__")).cast<std::string>() + ": unknown field '" + key +
                            "'");
    pyb::setattr(self, key.c_str(), item.second);
  }
}

pyb::object jsonNumber(double v) {
  return std::isfinite(v) ? pyb::object(pyb::float_(v)) : pyb::object(pyb::none());
}

pyb::object jsonLoads(const std::string& text) {
  return pyb::module_::import("json").attr("loads")(text);
}

void registerErrors(pyb::module_& m) {
  // ctr.InputError(ValueError): bad input files and values; str() is the library's "FILE:LINE: key 'KEY': MESSAGE"
  // (the CLI prints it after "error: "); attributes file, line (0 if unknown), key and message.
  // Kept for the life of the process (no destructor running after the interpreter is gone).
  static auto* const error_type = new pyb::exception<io::InputError>(m, "InputError", PyExc_ValueError);
  pyb::exception<io::InputError>& input_error = *error_type;
  input_error.doc() =
      "Bad input (file missing, malformed, out of range). str(e) is the library's message \"FILE:LINE: key 'KEY': "
      "MESSAGE\", as the ctr CLI prints it; e.file, e.line (0 when unknown), e.key and e.message hold its parts.";
  pyb::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const io::InputError& e) {
      const pyb::handle type(error_type->ptr());
      pyb::object exc = type(e.what());
      exc.attr("file") = e.file();
      exc.attr("line") = e.line();
      exc.attr("key") = e.key();
      exc.attr("message") = e.message();
      PyErr_SetObject(type.ptr(), exc.ptr());
    }
  });
}

}  // namespace ctr::py
