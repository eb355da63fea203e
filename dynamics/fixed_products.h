// Matrix-vector products for matrices whose row count is fixed at compile time (the 6-, 12- and
// 18-row blocks of the mass matrix, its inverse blocks and the ID's contact matrices), as a sum of
// fixed-size columns. Eigen sends products above a small size, and any with dynamic columns, to
// its general matrix-vector kernel, whose set-up costs more than the arithmetic at these sizes.
#pragma once

#include <Eigen/Core>

namespace hyq::dynamics {

/// m v, column by column (m: fixed rows, fixed or dynamic columns; v: at least m.cols() entries).
template <class Mat, class Vec>
Eigen::Matrix<double, Mat::RowsAtCompileTime, 1> Times(const Mat& m, const Vec& v) {
  static_assert(Mat::RowsAtCompileTime != Eigen::Dynamic);
  Eigen::Matrix<double, Mat::RowsAtCompileTime, 1> s =
      Eigen::Matrix<double, Mat::RowsAtCompileTime, 1>::Zero();
  for (Eigen::Index k = 0; k < m.cols(); ++k) s += m.col(k) * v(k);
  return s;
}

/// ½ vᵀ M v for the symmetric M (the kinetic energy of v), from M v by columns.
template <class Mat, class Vec>
double HalfQuadraticForm(const Mat& m, const Vec& v) {
  return 0.5 * v.dot(Times(m, v));
}

}  // namespace hyq::dynamics
