/// @file common.hpp
/// @brief Shared helpers of the `ctr` Python module: configurations from numpy, the per-thread model workspace,
/// keyword-argument construction of option structs, and the registration function of each binding file.
#pragma once

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>

#include <string>
#include <vector>

#include "ctr/model/configuration.hpp"
#include "ctr/model/kinematics.hpp"
#include "ctr/model/robot.hpp"

namespace ctr::py {

namespace pyb = pybind11;

/// @brief The calling thread's model workspace (solver buffers; one per thread, so calls without the GIL may run
/// concurrently from several Python threads).
Workspace& workspace();

/// @brief Converts an array-like of numbers to a vector; `what` names the argument in errors (ValueError).
Eigen::VectorXd toVector(const pyb::handle& obj, const std::string& what);
/// @brief Converts an array-like to a rows x cols matrix (a 1-D input of length cols is one row).
Eigen::MatrixXd toMatrix(const pyb::handle& obj, const std::string& what, int cols);

/// @brief Configuration from Python values: None means the default (as the CLI), else n numbers each. Projected onto
/// the admissible set within kAdmissibilityTolerance (as the CLI does); a larger violation raises ValueError
/// "beta: configuration is not admissible: ..." (or alpha). With `swept_tube` >= 0 (0-based) that tube's rotation is
/// `swept_angle` before the projection (the start of a sweep, as `ctr sweep`).
Configuration toConfiguration(const Robot& robot, const pyb::handle& alpha, const pyb::handle& beta,
                              int swept_tube = -1, double swept_angle = 0.0);

/// @brief (alpha, beta) of a configuration as a tuple of numpy arrays.
pyb::tuple configurationTuple(const Configuration& q);

/// @brief Rows of configurations as (alpha (K, n), beta (K, n)) numpy arrays.
pyb::tuple configurationArrays(const std::vector<Configuration>& qs, int n);

/// @brief A 3-vector as a numpy array (copy).
pyb::array_t<double> array3(const Eigen::Vector3d& v);

/// @brief Sets the attributes named by `kwargs` on `self` (TypeError for an unknown name).
void setAttributes(pyb::object self, const pyb::kwargs& kwargs);

/// @brief Adds `__init__(**kwargs)`, `__repr__` listing `fields`, `__copy__` and `__deepcopy__` to an options class.
template <class T, class Class>
void addOptionsProtocol(Class& cls, std::vector<std::string> fields) {
  cls.def(pyb::init([](const pyb::kwargs& kwargs) {
            pyb::object o = pyb::cast(T{});
            setAttributes(o, kwargs);
            return o.cast<T>();
          }),
          "Defaults of the library; keyword arguments set fields by name.");
  cls.def("__copy__", [](const T& self) { return T(self); });
  cls.def("__deepcopy__", [](const T& self, const pyb::dict&) { return T(self); });
  cls.def("__repr__", [fields](const pyb::object& self) {
    std::string out = pyb::str(self.get_type().attr("__name__")).cast<std::string>() + "(";
    for (std::size_t k = 0; k < fields.size(); ++k)
      out += (k ? ", " : "") + fields[k] + "=" + pyb::repr(self.attr(fields[k].c_str())).cast<std::string>();
    return out + ")";
  });
}

/// @brief Per-row results of a sequence of solves as a dict of numpy arrays: twist (K, n-1), tip_position and
/// tip_tangent (K, 3), NaN where not converged; stability, converged, stable (K,); status (list of str).
pyb::dict solutionRows(const std::vector<const Solution*>& sols, int n);

/// @brief A contact site as a dict (kind, tube, outer, inner 1-based; s).
pyb::dict siteDict(const ContactSite& site);
/// @brief Contact sites as dicts.
pyb::list siteList(const std::vector<ContactSite>& sites);

/// @brief A number as the CLI's JSON holds it: a float, or None for NaN and infinities (nlohmann::json writes null).
pyb::object jsonNumber(double v);

/// @brief Python dict of parsed JSON text (json.loads).
pyb::object jsonLoads(const std::string& text);

// Registration of each area (one file each).
void registerErrors(pyb::module_& m);
void registerModel(pyb::module_& m);
void registerFriction(pyb::module_& m);
void registerIk(pyb::module_& m);
#ifdef CTR_PY_WITH_ENVIRONMENTS
void registerEnvironments(pyb::module_& m);
#endif
#ifdef CTR_PY_WITH_PLANNER
void registerPlanner(pyb::module_& m);
void registerCampaign(pyb::module_& m);
#endif
#ifdef CTR_PY_WITH_DIAGNOSIS
void registerDiagnosis(pyb::module_& m);
#endif
#ifdef CTR_PY_WITH_DESIGN
void registerDesign(pyb::module_& m);
#endif

}  // namespace ctr::py
