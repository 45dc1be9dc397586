// The parts of the rangeseg Python module, each registered by its own function.
#pragma once

#include <pybind11/pybind11.h>

namespace rangeseg::python {

namespace py = pybind11;

void bind_cloud(py::module_& m);     ///< Cloud, read_cloud, read_depth_png, ...
void bind_pipeline(py::module_& m);  ///< Pipeline, Result
void bind_eval(py::module_& m);      ///< evaluate

}  // namespace rangeseg::python
