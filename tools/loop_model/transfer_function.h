// A discrete-time transfer function at one sample period, as a ratio of polynomials in z:
//   H(z) = N(z) / D(z),   N(z) = Σ n_i z^i,  D(z) = Σ d_i z^i   (coefficients in ascending powers)
// for the blocks of a feedback loop: their sums and products, delays z^−m, their frequency
// response H(e^{jωT}), and their state-space form (Realize: controllable canonical), connected
// with the others into a closed loop whose eigenvalues are its poles [Franklin, Powell &
// Workman, "Digital Control of Dynamic Systems", 3rd ed. 1998, ch. 4 and 6]. Products and sums
// cancel nothing: a block's poles are its own.
#pragma once

#include <complex>
#include <vector>

#include <Eigen/Core>

namespace hyq::loop_model {

/// Coefficients of a polynomial in z, ascending powers (p[i] multiplies z^i).
using Polynomial = std::vector<double>;

/// a · b.
Polynomial Multiply(const Polynomial& a, const Polynomial& b);
/// a + b.
Polynomial Add(const Polynomial& a, const Polynomial& b);
/// p(z) by Horner's rule.
std::complex<double> Evaluate(const Polynomial& p, std::complex<double> z);
/// The roots of p (leading zero coefficients dropped; trailing ones are roots at z = 0): the
/// eigenvalues of its companion matrix. Throws std::invalid_argument for a zero polynomial.
Eigen::VectorXcd Roots(const Polynomial& p);

class TransferFunction {
 public:
  /// H = 1.
  TransferFunction() : num_{1.0}, den_{1.0} {}
  TransferFunction(Polynomial num, Polynomial den);
  /// The constant k.
  static TransferFunction Gain(double k) { return TransferFunction({k}, {1.0}); }
  /// z^−m, m ≥ 0 whole samples of delay.
  static TransferFunction Delay(int m);

  const Polynomial& num() const noexcept { return num_; }
  const Polynomial& den() const noexcept { return den_; }

  /// H(z) at a point; on the unit circle z = e^{jθ}, θ = ω T, the frequency response.
  std::complex<double> At(std::complex<double> z) const;
  /// H(e^{jθ}).
  std::complex<double> AtAngle(double theta_rad) const;

  TransferFunction operator*(const TransferFunction& o) const;
  TransferFunction operator+(const TransferFunction& o) const;

  /// The roots of D.
  Eigen::VectorXcd Poles() const { return Roots(den_); }

 private:
  Polynomial num_, den_;
};

/// x[n+1] = A x[n] + B u[n],  y[n] = C x[n] + D u[n]  (single input, single output).
struct StateSpace {
  Eigen::MatrixXd A;
  Eigen::VectorXd B;
  Eigen::RowVectorXd C;
  double D = 0.0;
  int order() const { return static_cast<int>(A.rows()); }
};

/// H in controllable canonical form: D monic of degree n, N = b_n D + N' (deg N' < n),
/// x_i+ = x_{i+1} (i < n − 1), x_{n−1}+ = u − Σ d_i x_i, y = Σ n'_i x_i + b_n u.
/// Throws std::invalid_argument when H is improper (deg N > deg D).
StateSpace Realize(const TransferFunction& H);

/// The eigenvalues of A after diagonal balancing (radix-2 row and column scaling, as EISPACK's
/// balanc), which leaves them unchanged and makes the QR iteration's error relative to the
/// balanced norm.
Eigen::VectorXcd Eigenvalues(Eigen::MatrixXd A);

}  // namespace hyq::loop_model
