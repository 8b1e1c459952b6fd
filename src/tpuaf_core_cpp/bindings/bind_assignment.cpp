// Linear sum assignment (assignment.hpp): scipy.optimize.linear_sum_assignment's results without
// importing scipy.
#include <pybind11/numpy.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "tpuaf_core/assignment.hpp"

namespace py = pybind11;

namespace {

py::array_t<std::int64_t> int64_array(const std::vector<std::int64_t>& values) {
  py::array_t<std::int64_t> out(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), out.mutable_data());
  return out;
}

}  // namespace

void tpuaf::bindings::bind_assignment(py::module_& m) {
  m.def(
      "linear_sum_assignment",
      [](py::array_t<double, py::array::c_style | py::array::forcecast> cost) {
        if (cost.ndim() != 2) {
          throw py::value_error("linear_sum_assignment: expected a matrix (2-D array), got a " +
                                std::to_string(cost.ndim()) + "-D array");
        }
        if (cost.shape(0) > INT_MAX || cost.shape(1) > INT_MAX) {
          throw py::value_error("linear_sum_assignment: cost matrix too large");
        }
        const int rows = static_cast<int>(cost.shape(0));
        const int cols = static_cast<int>(cost.shape(1));
        Assignment a;
        try {
          py::gil_scoped_release release;
          a = linear_sum_assignment(cost.data(), rows, cols);
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
        return py::make_tuple(int64_array(a.rows), int64_array(a.cols));
      },
      py::arg("cost"),
      "Minimum-cost assignment of rows to columns of the 2-D `cost` matrix (any unit, any "
      "numeric dtype, converted to float64; +inf forbids a pair): (row_ind, col_ind), int64 "
      "arrays of min(rows, cols) pairs, row_ind ascending, total cost cost[row_ind, "
      "col_ind].sum(). Equal to scipy.optimize.linear_sum_assignment(cost), ties included. "
      "ValueError on NaN or -inf entries or when no assignment avoids +inf.");
}
