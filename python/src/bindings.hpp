// The parts of the rangeseg Python module, each registered by its own function.
#pragma once

#include <pybind11/pybind11.h>

#include <string>

namespace rangeseg::python {

namespace py = pybind11;

void bind_cloud(py::module_& m);     ///< Cloud, read_cloud, read_depth_png, ...
void bind_pipeline(py::module_& m);  ///< Pipeline, Result
void bind_eval(py::module_& m);      ///< evaluate

/// A number in a message as the shortest text that reads back as it (not "%f": 1e-09 stays
/// 1e-09).
std::string number_text(double value);

/// Issues a Python UserWarning (an exception when the warning filters make it one).
void user_warning(const std::string& message);

}  // namespace rangeseg::python
