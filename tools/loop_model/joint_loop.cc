#include "tools/loop_model/joint_loop.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace hyq::loop_model {
namespace {

constexpr double kPi = std::numbers::pi;
// a pole this close to the unit circle counts as on it (not stable)
constexpr double kStableRadius = 1.0 - 1e-9;

// φ wrapped to (−π, π]
double Wrap(double phi) {
  phi = std::remainder(phi, 2.0 * kPi);
  return phi <= -kPi ? phi + 2.0 * kPi : phi;
}

// the branch of arg(c) nearest `near`
double Unwrap(std::complex<double> c, double near) {
  const double a = std::arg(c);
  return a + 2.0 * kPi * std::round((near - a) / (2.0 * kPi));
}

}  // namespace

TransferFunction Controller(const JointLoop& c) {
  const double T = c.period_s, a = c.velocity_alpha;
  // (1): kp + ki T z/(z − 1) + kd α (z − 1)/(T (z − (1 − α)))
  TransferFunction C = TransferFunction::Gain(c.kp);
  if (c.ki != 0.0) C = C + TransferFunction({0.0, c.ki * T}, {-1.0, 1.0});
  if (c.kd != 0.0) C = C + TransferFunction({-c.kd * a / T, c.kd * a / T}, {-(1.0 - a), 1.0});
  return C;
}

namespace {

void Check(const JointLoop& c, int extra) {
  if (!(c.period_s > 0) || !(c.inertia_kgm2 > 0) || c.delay_cycles < 0 || extra < 0 ||
      !(c.velocity_alpha > 0 && c.velocity_alpha <= 1))
    throw std::invalid_argument("joint loop: expected T > 0, I > 0, delays >= 0 and 0 < alpha <= 1");
}

// the share of T² τ / I in q[n+1]: 1 (semi-implicit Euler), ½ (zero-order hold)
double PositionShare(Mechanics m) { return m == Mechanics::kSemiImplicitEuler ? 1.0 : 0.5; }

}  // namespace

std::complex<double> OpenLoopAt(const JointLoop& c, int extra, double theta) {
  Check(c, extra);
  const double T = c.period_s, I = c.inertia_kgm2;
  const std::complex<double> z = std::polar(1.0, theta), zm1 = z - 1.0;
  // the mechanics: P_v = (T/I)/(z − 1), P_q = (T²/I)(h z + 1 − h)/(z − 1)²
  const std::complex<double> Pv = (T / I) / zm1;
  const double h = PositionShare(c.mechanics);
  const std::complex<double> Pq = (T * T / I) * (h * z + (1.0 - h)) / (zm1 * zm1);
  const std::complex<double> Zb = c.motion.At(z) + c.viscous_Nms;
  // (2)
  return std::pow(z, -static_cast<double>(c.delay_cycles + extra)) * Controller(c).At(z) *
         c.actuator.At(z) * Pq / (1.0 + Zb * Pv);
}

Eigen::MatrixXd ClosedLoopMatrix(const JointLoop& c, int extra) {
  Check(c, extra);
  const double T = c.period_s, I = c.inertia_kgm2, h = PositionShare(c.mechanics);
  const StateSpace D = Realize(TransferFunction::Delay(c.delay_cycles + extra));
  const StateSpace K = Realize(Controller(c));
  const StateSpace A = Realize(c.actuator);
  const StateSpace Z = Realize(c.motion + TransferFunction::Gain(c.viscous_Nms));
  // the state [x_delay, x_controller, x_actuator, x_motion, q̇, q]
  const int nd = D.order(), nk = K.order(), na = A.order(), nz = Z.order();
  const int od = 0, ok = nd, oa = ok + nk, oz = oa + na, iv = oz + nz, iq = iv + 1, n = iq + 1;
  using Row = Eigen::RowVectorXd;
  // the signals as rows over the state: e = −q, the delayed e, u, τ
  Row e = Row::Zero(n);
  e(iq) = -1.0;
  Row ed = D.D * e;
  ed.segment(od, nd) += D.C;
  Row u = K.D * ed;
  u.segment(ok, nk) += K.C;
  Row tau = A.D * u;
  tau.segment(oa, na) += A.C;
  tau.segment(oz, nz) -= Z.C;
  tau(iv) -= Z.D;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n, n);
  M.block(od, od, nd, nd) = D.A;
  M.middleRows(od, nd) += D.B * e;
  M.block(ok, ok, nk, nk) += K.A;
  M.middleRows(ok, nk) += K.B * ed;
  M.block(oa, oa, na, na) += A.A;
  M.middleRows(oa, na) += A.B * u;
  M.block(oz, oz, nz, nz) += Z.A;
  M.block(oz, iv, nz, 1) += Z.B;
  // q̇+ = q̇ + (T/I) τ;  q+ = q + T q̇ + h (T²/I) τ
  M.row(iv) = (T / I) * tau;
  M(iv, iv) += 1.0;
  M.row(iq) = h * (T * T / I) * tau;
  M(iq, iv) += T;
  M(iq, iq) += 1.0;
  return M;
}

Eigen::VectorXcd ClosedLoopPoles(const JointLoop& c, int extra) {
  return Eigenvalues(ClosedLoopMatrix(c, extra));
}

bool ClosedLoopStable(const JointLoop& c, int extra) {
  const Eigen::VectorXcd p = ClosedLoopPoles(c, extra);
  for (Eigen::Index i = 0; i < p.size(); ++i)
    if (std::abs(p(i)) >= kStableRadius) return false;
  return true;
}

Margins ComputeMargins(const JointLoop& loop, double f_lo_hz) {
  const double T = loop.period_s;
  Margins m;
  m.delay_margin_s = std::numeric_limits<double>::infinity();
  m.gain_margin = std::numeric_limits<double>::infinity();
  const bool stable = ClosedLoopStable(loop, 0);
  m.stable = stable;
  const double f_hi = 0.4999 / T;
  constexpr int kGrid = 6000;
  auto at = [&](double f) { return OpenLoopAt(loop, 0, 2.0 * kPi * f * T); };
  auto f_of = [&](int i) { return f_lo_hz * std::pow(f_hi / f_lo_hz, static_cast<double>(i) / (kGrid - 1)); };
  double f0 = f_of(0);
  std::complex<double> l0 = at(f0);
  double phase0 = std::arg(l0);
  for (int i = 1; i < kGrid; ++i) {
    const double f1 = f_of(i);
    const std::complex<double> l1 = at(f1);
    const double phase1 = Unwrap(l1, phase0);
    // gain crossover: log|L| changes sign; bisection on it
    if ((std::abs(l0) - 1.0) * (std::abs(l1) - 1.0) < 0.0) {
      double lo = f0, hi = f1;
      const bool falling = std::abs(l0) > 1.0;
      for (int k = 0; k < 60; ++k) {
        const double mid = std::sqrt(lo * hi);
        ((std::abs(at(mid)) > 1.0) == falling ? lo : hi) = mid;
      }
      const double fc = std::sqrt(lo * hi);
      const double pm = Wrap(kPi + std::arg(at(fc)));
      // the extra delay that turns the phase at fc to −π (mod 2π): zero for an unstable loop
      double tau = 0.0;
      if (stable) {
        const double lag = pm >= 0.0 ? pm : pm + 2.0 * kPi;
        tau = lag / (2.0 * kPi * fc);
      }
      if (!m.has_crossover || tau < m.delay_margin_s) {
        m.has_crossover = true;
        m.crossover_hz = fc;
        m.phase_margin_deg = pm * 180.0 / kPi;
        m.delay_margin_s = tau;
      }
    }
    // phase crossover: the unwrapped phase passes −π − 2πk
    const double k0 = std::floor((phase0 + kPi) / (2.0 * kPi));
    const double k1 = std::floor((phase1 + kPi) / (2.0 * kPi));
    if (k0 != k1) {
      const double target = -kPi + 2.0 * kPi * std::max(k0, k1);
      double lo = f0, hi = f1, plo = phase0;
      for (int k = 0; k < 60; ++k) {
        const double mid = std::sqrt(lo * hi);
        const double pmid = Unwrap(at(mid), plo);
        if ((pmid - target) * (plo - target) > 0.0) {
          lo = mid;
          plo = pmid;
        } else {
          hi = mid;
        }
      }
      const double fp = std::sqrt(lo * hi);
      const double mag = std::abs(at(fp));
      if (mag < 1.0 && 1.0 / mag < m.gain_margin) {
        m.gain_margin = 1.0 / mag;
        m.phase_crossover_hz = fp;
      }
    }
    f0 = f1;
    l0 = l1;
    phase0 = phase1;
  }
  if (!stable) m.delay_margin_s = 0.0;
  return m;
}

ClosedLoopRoot DominantRoot(const JointLoop& loop, int extra, bool oscillatory) {
  const Eigen::VectorXcd p = ClosedLoopPoles(loop, extra);
  ClosedLoopRoot r;
  r.magnitude = -1.0;
  for (Eigen::Index i = 0; i < p.size(); ++i) {
    if (oscillatory && std::abs(p(i).imag()) <= 1e-9) continue;
    const double mag = std::abs(p(i));
    // the largest; of a conjugate pair the one above the real axis
    if (mag > r.magnitude + 1e-12 || (std::abs(mag - r.magnitude) <= 1e-12 && p(i).imag() > r.z.imag())) {
      r.z = p(i);
      r.magnitude = mag;
    }
  }
  if (r.magnitude < 0.0) return DominantRoot(loop, extra, false);  // none off the axis
  r.frequency_hz = std::abs(std::arg(r.z)) / (2.0 * kPi * loop.period_s);
  return r;
}

int MaxStableExtraCycles(const JointLoop& loop, int k_max) {
  for (int k = 0; k <= k_max; ++k)
    if (!ClosedLoopStable(loop, k)) return k - 1;
  return k_max;
}

}  // namespace hyq::loop_model
