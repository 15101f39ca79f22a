// The `ctr` Python module: concentric tube robots from Python (numpy in and out). README.md, "Python".
#include "common.hpp"

PYBIND11_MODULE(ctr, m) {
  m.doc() =
      "ctr -- friction-aware modeling and motion planning of concentric tube robots (C++ library bindings).\n\n"
      "SI units (m, rad, N m^2); tubes numbered from the outermost; arrays are numpy float64. Configurations are "
      "(alpha, beta) pairs of length-n sequences; None means the CLI's default. Long calls (solves, sweeps, "
      "environment building, planning, diagnosis) release the GIL. Bad input raises ctr.InputError (a ValueError) "
      "with the library's message naming the file, line and key.";
  m.attr("__version__") = CTR_VERSION;
  ctr::py::registerErrors(m);
  ctr::py::registerModel(m);
  ctr::py::registerFriction(m);
  ctr::py::registerIk(m);
#ifdef CTR_PY_WITH_ENVIRONMENTS
  ctr::py::registerEnvironments(m);
#endif
#ifdef CTR_PY_WITH_PLANNER
  ctr::py::registerPlanner(m);
  ctr::py::registerCampaign(m);
#endif
#ifdef CTR_PY_WITH_DIAGNOSIS
  ctr::py::registerDiagnosis(m);
#endif
#ifdef CTR_PY_WITH_DESIGN
  ctr::py::registerDesign(m);
#endif
}
