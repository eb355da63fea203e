// The trunk's disturbance observer (servo/estimation/disturbance_observer.h), a generalized-
// momentum observer, against independent references: a constant wrench at rest (r and d_b follow
// K/(s + K) exactly), the same wrench on the robot flying under gravity with its legs driven
// (the motion integrated here from the model's forward dynamics, so τ_ext is known exactly), a
// lift-off and swing (the feet's forces do not leak into d_b), white noise on v (it reaches r
// scaled by K M, a differentiator's 1/dt never appears), the low-passed residual it replaced
// (kept here as an oracle: the same filter in continuous time), the holds, the clamps and no
// heap in the cycle.
#include "servo/estimation/disturbance_observer.h"

#include <cmath>
#include <limits>
#include <memory>
#include <random>

#include <gtest/gtest.h>

#include "dynamics/configuration.h"
#include "dynamics/kinematics.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/dynamics/rk4.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::servo {
namespace {

using dynamics::CycleDynamics;
using dynamics::kNumBaseDofs;
using dynamics::MatrixV;
using dynamics::VectorQ;
using dynamics::VectorV;
using testing::HyqModel;
using Vector6d = DisturbanceObserver::Vector6d;

constexpr double kDt = 1e-3;
constexpr double kBandwidthHz = 3.0;
const double kK = 2.0 * M_PI * kBandwidthHz;

DisturbanceObserverConfig Config() {
  DisturbanceObserverConfig c;
  c.enabled = true;
  c.bandwidth_hz = kBandwidthHz;
  return c;
}

// a 5 kg payload at (0.10, 0.05, 0.08) m in the level trunk: its weight (world) and moment about
// the base origin (base frame)
Vector6d PayloadWrench() {
  const Eigen::Vector3d force(0.0, 0.0, -5.0 * 9.81);
  Vector6d w;
  w << force, Eigen::Vector3d(0.10, 0.05, 0.08).cross(force);
  return w;
}

// the 1 − e^{−K k dt} of K/(s + K) after k cycles of a constant input
double StepResponse(int k) { return 1.0 - std::exp(-kK * k * kDt); }

std::unique_ptr<CycleDynamics> Dynamics(const VectorQ& q, const VectorV& v) {
  auto d = std::make_unique<CycleDynamics>();
  EXPECT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), q, v, d.get()), dynamics::DynamicsStatus::kOk);
  return d;
}

// the contact-point Jacobians the observer splits with
std::array<dynamics::FootJacobian, dynamics::kNumFeet> ContactJacobians(const CycleDynamics& d) {
  std::array<dynamics::FootJacobian, dynamics::kNumFeet> J;
  for (int f = 0; f < dynamics::kNumFeet; ++f) {
    Eigen::Vector3d unused;
    dynamics::ContactPointJacobian(HyqModel(), d.feet, f, Eigen::Vector3d::UnitZ(),
                                   &J[static_cast<std::size_t>(f)], &unused);
  }
  return J;
}

// P = [I₆ | −J_f,bᵀ J_f,legᵀ⁻¹ per leg]: d_b = P τ_ext when each leg's rows carry only its foot's force
Eigen::Matrix<double, 6, dynamics::kNv> Projection(const CycleDynamics& d) {
  const auto J = ContactJacobians(d);
  Eigen::Matrix<double, 6, dynamics::kNv> P = Eigen::Matrix<double, 6, dynamics::kNv>::Zero();
  P.leftCols<6>().setIdentity();
  for (int f = 0; f < dynamics::kNumFeet; ++f) {
    const auto& J_f = J[static_cast<std::size_t>(f)];
    const int col = kNumBaseDofs + 3 * f;
    P.middleCols<3>(col) =
        -J_f.leftCols<6>().transpose() * Eigen::Matrix3d(J_f.middleCols<3>(col).transpose()).inverse();
  }
  return P;
}

// The robot standing still (q near standing, v = 0) with the wrench w on its trunk: the feet
// carry the rest (the least-norm forces with Σ J_f,bᵀ f_f = g_b − w) and the joints hold it,
// τ = g_j − Σ J_f,jᵀ f_f. Then τ_ext = M v̇ + h − Sᵀ τ = Σ J_fᵀ f_f + [w; 0].
struct AtRest {
  VectorQ q;
  std::unique_ptr<CycleDynamics> dyn;
  dynamics::VectorJ tau;
  VectorV tau_ext;
};

AtRest StandStill(const Vector6d& w) {
  AtRest s;
  s.q = HyqModel().StandingQ();
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitX()) *
                                Eigen::AngleAxisd(-0.02, Eigen::Vector3d::UnitY()));
  s.q.segment<4>(3) << tilt.w(), tilt.x(), tilt.y(), tilt.z();
  s.dyn = Dynamics(s.q, VectorV::Zero());
  const auto J = ContactJacobians(*s.dyn);
  Eigen::Matrix<double, 6, 12> A;
  for (int f = 0; f < 4; ++f) A.middleCols<3>(3 * f) = J[static_cast<std::size_t>(f)].leftCols<6>().transpose();
  const Vector6d b = s.dyn->bias.head<6>() - w;
  const Eigen::Matrix<double, 12, 1> forces = A.transpose() * (A * A.transpose()).ldlt().solve(b);
  s.tau_ext.setZero();
  s.tau_ext.head<6>() = w;
  for (int f = 0; f < 4; ++f)
    s.tau_ext += J[static_cast<std::size_t>(f)].transpose() * forces.segment<3>(3 * f);
  s.tau = (s.dyn->bias - s.tau_ext).tail<dynamics::kNumJoints>();
  return s;
}

TEST(DisturbanceObserver, AWrenchAtRestIsFoundWithTheFirstOrderResponse) {
  const Vector6d w = PayloadWrench();
  const AtRest s = StandStill(w);
  DisturbanceObserver obs(HyqModel(), Config(), kDt);
  (void)obs.Update(*s.dyn, VectorV::Zero(), s.tau);  // the first cycle anchors the momentum
  EXPECT_TRUE(obs.held());
  EXPECT_EQ(obs.wrench(), Vector6d::Zero());
  int at63 = -1;
  for (int k = 1; k <= 400; ++k) {
    const Vector6d& d = obs.Update(*s.dyn, VectorV::Zero(), s.tau);
    ASSERT_FALSE(obs.held());
    // r is τ_ext (all 18 rows) through K/(s + K), sampled exactly; so is d_b, w's part of it
    ASSERT_TRUE(testing::NearRel(obs.residual(), (StepResponse(k) * s.tau_ext).eval(), 1e-9)) << k;
    ASSERT_TRUE(testing::NearRel(d, (StepResponse(k) * w).eval(), 1e-9)) << k;
    if (at63 < 0 && d(2) / w(2) >= 1.0 - std::exp(-1.0)) at63 = k;
  }
  // 63 % at t = 1/K (53.05 ms at 3 Hz): the first cycle at or after it
  EXPECT_EQ(at63, static_cast<int>(std::ceil(1.0 / (kK * kDt))));
  EXPECT_TRUE(testing::NearRel(obs.wrench(), w, 1e-3));  // 400 ms = 7.5 / K: e^{−7.5} left
}

// The robot in the air under gravity, its trunk pushed by the constant wrench w, the joints held
// near the standing posture by a PD and driven around it by sinusoidal torques, from a tumbling
// initial velocity: q(t), v(t) integrated from the model's forward dynamics M v̇ = Sᵀ τ + [w; 0] − h
// (RK4, 10 steps per cycle), so τ_ext = [w; 0] exactly and M changes (Ṁ v ≠ 0) along the way.
struct Flight {
  std::vector<VectorQ> q;
  std::vector<VectorV> v;
  std::vector<dynamics::VectorJ> tau;  // the joint torques at each cycle's start (the load cells)
};

dynamics::VectorJ DriveTorque(const VectorQ& q, const VectorV& v, double t) {
  const dynamics::VectorJ q0 = HyqModel().q_standing;
  dynamics::VectorJ tau;
  for (int j = 0; j < dynamics::kNumJoints; ++j)
    tau(j) = 150.0 * (q0(j) - q(dynamics::QIndexOfJoint(j))) - 3.0 * v(dynamics::VIndexOfJoint(j)) +
             (8.0 + 2.0 * (j % 3)) * std::sin(2.0 * M_PI * 1.5 * t + 0.5 * j);
  return tau;
}

Flight Fly(const Vector6d& w, int cycles) {
  const dynamics::Model& model = HyqModel();
  auto d = std::make_unique<CycleDynamics>();
  const auto vdot = [&](const VectorQ& q, const VectorV& v, double t) {
    EXPECT_EQ(dynamics::ComputeCycleDynamics(model, q, v, d.get()), dynamics::DynamicsStatus::kOk);
    VectorV f = -d->bias;
    f.head<6>() += w;
    f.tail<dynamics::kNumJoints>() += DriveTorque(q, v, t);
    return VectorV(d->M.ldlt().solve(f));
  };
  Flight fl;
  VectorQ q = model.StandingQ();
  VectorV v;
  v << 0.3, -0.2, 0.1, 0.4, -0.3, 0.5, 1.0, -0.8, 1.2, -1.0, 0.6, -0.9, 0.8, -1.1, 0.7, -0.6, 1.0, -0.8;
  constexpr int kSub = 10;
  const double h = kDt / kSub;
  for (int k = 0; k <= cycles; ++k) {
    const double t = k * kDt;
    fl.q.push_back(q);
    fl.v.push_back(v);
    fl.tau.push_back(DriveTorque(q, v, t));
    for (int i = 0; i < kSub; ++i) testing::Rk4Step(vdot, t + i * h, h, &q, &v);
  }
  return fl;
}

TEST(DisturbanceObserver, AWrenchOnTheTrunkInAKnownMotionIsFound) {
  const Vector6d w = PayloadWrench();
  constexpr int kCycles = 400;
  const Flight fl = Fly(w, kCycles);
  DisturbanceObserver obs(HyqModel(), Config(), kDt);
  VectorV tau_ext = VectorV::Zero();
  tau_ext.head<6>() = w;
  const double alpha = 1.0 - std::exp(-kK * kDt);
  // (2) takes M v̇ and h − Sᵀ τ_m both over the cycle, so r is off by second-order terms only.
  // The yardstick: h − Sᵀ τ_m taken at the cycle's end instead (the filter this observer replaced)
  // is off by half a cycle's change of it, low-passed (`shift`), and d_b by half a cycle's change
  // of P (h − Sᵀ τ_m) (`shift_b`). Ṁ v, low-passed, is far larger than either: a missing or wrong
  // Ṁ v would fail.
  double r_err = 0.0, d_err = 0.0, shift_max = 0.0, shift_b_max = 0.0, mdotv_max = 0.0;
  VectorV shift = VectorV::Zero(), mdotv = VectorV::Zero(), known_prev = VectorV::Zero();
  Vector6d shift_b = Vector6d::Zero(), known_b_prev = Vector6d::Zero();
  std::unique_ptr<CycleDynamics> prev;
  for (int k = 0; k <= kCycles; ++k) {
    auto d = Dynamics(fl.q[k], fl.v[k]);
    VectorV known = d->bias;
    known.tail<dynamics::kNumJoints>() -= fl.tau[k];
    const Vector6d known_b = Projection(*d) * known;
    const Vector6d& d_b = obs.Update(*d, fl.v[k], fl.tau[k]);
    if (k > 0) {
      shift += alpha * (0.5 * (known - known_prev) - shift);
      shift_max = std::max(shift_max, shift.cwiseAbs().maxCoeff());
      shift_b += alpha * (0.5 * (known_b - known_b_prev) - shift_b);
      shift_b_max = std::max(shift_b_max, shift_b.cwiseAbs().maxCoeff());
      const VectorV Mdot_v = (d->M - prev->M) * (0.5 * (fl.v[k] + fl.v[k - 1])) / kDt;
      mdotv += alpha * (Mdot_v - mdotv);
      mdotv_max = std::max(mdotv_max, mdotv.cwiseAbs().maxCoeff());
      ASSERT_FALSE(obs.held()) << k;
      r_err = std::max(r_err, (obs.residual() - StepResponse(k) * tau_ext).cwiseAbs().maxCoeff());
      d_err = std::max(d_err, (d_b - StepResponse(k) * w).cwiseAbs().maxCoeff());
    }
    known_prev = known;
    known_b_prev = known_b;
    prev = std::move(d);
  }
  std::printf("flight: |r − K/(s+K) τ_ext| ≤ %.4f (shift %.4f), |d_b − K/(s+K) w| ≤ %.4f "
              "(projected shift %.4f); Ṁ v low-passed up to %.3f\n",
              r_err, shift_max, d_err, shift_b_max, mdotv_max);
  EXPECT_LE(r_err, 0.05 * shift_max);
  EXPECT_LE(d_err, 0.05 * shift_b_max);
  EXPECT_LE(d_err, 0.002 * w.norm());
  EXPECT_GT(mdotv_max, 20.0 * shift_max);
  // the motion is not small: the trunk turned, the legs moved
  const VectorQ& q0 = fl.q.front();
  const VectorQ& q1 = fl.q.back();
  const Eigen::Quaterniond R0(q0(3), q0(4), q0(5), q0(6)), R1(q1(3), q1(4), q1(5), q1(6));
  EXPECT_GT(R0.angularDistance(R1), 0.1);
  EXPECT_GT((q1 - q0).tail<dynamics::kNumJoints>().cwiseAbs().maxCoeff(), 0.05);
}

// Standing on four feet with the wrench w on the trunk, then foot 0 lifts off (its force to zero
// at once, the other three take its share) and its leg swings (haa, hfe, kfe by 0.1, 0.5, −0.8
// rad and back in 0.3 s), the trunk held still: q, v, v̇ of the legs analytic, every foot's force
// and the joint torques from the model, so τ_ext = Σ J_fᵀ f_f + [w; 0] exactly and d_b = w
// throughout. The projected observer keeps d_b; the 18-row r split with the present Jacobians
// (`split`) carries the lifted foot's decaying force estimate through the swinging leg into d_b.
TEST(DisturbanceObserver, ALiftOffAndASwingDoNotLeakIntoTheWrench) {
  const Vector6d w = PayloadWrench();
  const AtRest rest = StandStill(w);
  constexpr double kLiftOff = 0.5, kSwing = 0.3;
  const Eigen::Vector3d a(0.1, 0.5, -0.8);
  DisturbanceObserver obs(HyqModel(), Config(), kDt);
  double d_err = 0.0, split_err = 0.0;
  for (int k = 0; k <= 1000; ++k) {
    const double t = k * kDt;
    VectorQ q = rest.q;
    VectorV v = VectorV::Zero(), vdot = VectorV::Zero();
    const bool lifted = t >= kLiftOff;
    if (lifted && t <= kLiftOff + kSwing) {
      const double phase = 2.0 * M_PI * (t - kLiftOff) / kSwing;
      for (int i = 0; i < 3; ++i) {
        q(dynamics::QIndexOfJoint(i)) += 0.5 * a(i) * (1.0 - std::cos(phase));
        v(dynamics::VIndexOfJoint(i)) = 0.5 * a(i) * std::sin(phase) * 2.0 * M_PI / kSwing;
        vdot(dynamics::VIndexOfJoint(i)) =
            0.5 * a(i) * std::cos(phase) * (2.0 * M_PI / kSwing) * (2.0 * M_PI / kSwing);
      }
    }
    auto d = Dynamics(q, v);
    const VectorV Mvdot_h = d->M * vdot + d->bias;
    // the feet carry what the trunk's rows need beyond w (least-norm), foot 0 nothing once lifted
    const auto J = ContactJacobians(*d);
    Eigen::Matrix<double, 6, 12> A = Eigen::Matrix<double, 6, 12>::Zero();
    for (int f = lifted ? 1 : 0; f < 4; ++f)
      A.middleCols<3>(3 * f) = J[static_cast<std::size_t>(f)].leftCols<6>().transpose();
    const Eigen::Matrix<double, 12, 1> forces =
        A.transpose() * (A * A.transpose()).ldlt().solve(Vector6d(Mvdot_h.head<6>() - w));
    VectorV tau_ext = VectorV::Zero();
    tau_ext.head<6>() = w;
    for (int f = 0; f < 4; ++f) tau_ext += J[static_cast<std::size_t>(f)].transpose() * forces.segment<3>(3 * f);
    const dynamics::VectorJ tau = (Mvdot_h - tau_ext).tail<dynamics::kNumJoints>();
    const Vector6d& d_b = obs.Update(*d, v, tau);
    if (t >= kLiftOff - 0.1) {
      d_err = std::max(d_err, (d_b - StepResponse(k) * w).cwiseAbs().maxCoeff());
      const Vector6d split = Projection(*d) * obs.residual();
      split_err = std::max(split_err, (split - StepResponse(k) * w).cwiseAbs().maxCoeff());
    }
  }
  std::printf("lift-off and swing: d_b within %.4f of K/(s+K) w; the filtered r split with the "
              "present Jacobians within %.1f\n", d_err, split_err);
  // the swing's acceleration steps at its start and end (a torque step at a sample), which the
  // trapezoid of (2) spreads over that cycle: ~0.2 N, forgotten with time constant 1/K
  EXPECT_LT(d_err, 0.01 * w.norm());
  EXPECT_GT(split_err, 0.1 * w.norm());
  EXPECT_GT(split_err, 20.0 * d_err);
}

// White noise σ on every component of the measured v, the robot at rest (q from the encoders,
// unaffected): r's noise is K_d M times the noise's difference filtered by the observer,
//   var(r_i) = (K_d)² · 2 / (2 − α) · σ² ‖M_i‖²,   α = K_d dt,
// i.e. about K σ ‖M_i‖, and d_b's likewise with the rows of P M. The raw residual
// M Δv / dt + h − Sᵀ τ_m (v̇ by difference) has √2 σ ‖M_i‖ / dt: K dt / √2 (1.3 % at 3 Hz) of it.
TEST(DisturbanceObserver, NoiseOnTheVelocityIsScaledByKTimesM) {
  const AtRest s = StandStill(PayloadWrench());
  DisturbanceObserver obs(HyqModel(), Config(), kDt);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  constexpr double kSigma = 0.01;  // 1 cm/s, 0.01 rad/s
  constexpr int kSkip = 1000, kCycles = 40000;
  auto d = std::make_unique<CycleDynamics>();
  VectorV sum = VectorV::Zero(), sum2 = VectorV::Zero(), diff2 = VectorV::Zero();
  VectorV v_prev = VectorV::Zero();
  Vector6d sum_b = Vector6d::Zero(), sum2_b = Vector6d::Zero();
  for (int k = 0; k <= kSkip + kCycles; ++k) {
    VectorV v;
    for (int i = 0; i < dynamics::kNv; ++i) v(i) = kSigma * n(rng);
    ASSERT_EQ(dynamics::ComputeCycleDynamics(HyqModel(), s.q, v, d.get()), dynamics::DynamicsStatus::kOk);
    (void)obs.Update(*d, v, s.tau);
    if (k > kSkip) {
      const VectorV e = obs.residual() - s.tau_ext;
      sum += e;
      sum2 += e.cwiseProduct(e);
      const Vector6d e_b = obs.wrench() - PayloadWrench();
      sum_b += e_b;
      sum2_b += e_b.cwiseProduct(e_b);
      const VectorV raw = s.dyn->M * (v - v_prev) / kDt;
      diff2 += raw.cwiseProduct(raw);
    }
    v_prev = v;
  }
  const double alpha = 1.0 - std::exp(-kK * kDt);
  for (int i = 0; i < dynamics::kNv; ++i) {
    const double sd = std::sqrt(sum2(i) / kCycles - (sum(i) / kCycles) * (sum(i) / kCycles));
    const double row = s.dyn->M.row(i).norm();
    const double predicted = alpha / kDt * std::sqrt(2.0 / (2.0 - alpha)) * kSigma * row;
    EXPECT_NEAR(sd, predicted, 0.05 * predicted) << "row " << i;
    EXPECT_NEAR(sd, kK * kSigma * row, 0.05 * kK * kSigma * row) << "row " << i;
    const double differentiator = std::sqrt(diff2(i) / kCycles);
    EXPECT_NEAR(differentiator, std::sqrt(2.0) * kSigma * row / kDt, 0.05 * std::sqrt(2.0) * kSigma * row / kDt);
    EXPECT_LT(sd, 0.015 * differentiator) << "row " << i;
  }
  const Eigen::Matrix<double, 6, dynamics::kNv> PM = Projection(*s.dyn) * s.dyn->M;
  for (int i = 0; i < 6; ++i) {
    const double sd = std::sqrt(sum2_b(i) / kCycles - (sum_b(i) / kCycles) * (sum_b(i) / kCycles));
    const double predicted = alpha / kDt * std::sqrt(2.0 / (2.0 - alpha)) * kSigma * PM.row(i).norm();
    EXPECT_NEAR(sd, predicted, 0.05 * predicted) << "d_b row " << i;
  }
}

// The filter this observer replaced: e ← e + α (M v̇ + h − Sᵀ τ_m − e), v̇ = (v_k − v_{k−1}) / dt.
// In continuous time it is the same K/(s + K) of the residual. Per cycle it sets M v̇ over the
// cycle against h − Sᵀ τ_m at the cycle's end, half a cycle apart, where (2) takes both over the
// cycle; noise on v reaches both alike (K M times it).
class LowPassedResidual {
 public:
  const VectorV& Update(const CycleDynamics& dyn, const VectorV& v, const dynamics::VectorJ& tau) {
    if (started_) {
      VectorV raw = dyn.M * ((v - v_prev_) / kDt) + dyn.bias;
      raw.tail<dynamics::kNumJoints>() -= tau;
      e_ += (1.0 - std::exp(-kK * kDt)) * (raw - e_);
    }
    started_ = true;
    v_prev_ = v;
    return e_;
  }

 private:
  bool started_ = false;
  VectorV v_prev_ = VectorV::Zero(), e_ = VectorV::Zero();
};

TEST(DisturbanceObserver, IsTheLowPassedResidualWithoutItsHalfCycleSkew) {
  const Vector6d w = PayloadWrench();
  const Flight fl = Fly(w, 300);
  VectorV tau_ext = VectorV::Zero();
  tau_ext.head<6>() = w;
  // max |r − K/(s+K) τ_ext| of each along the flight, and max |r − e|, with noise σ on v or none
  struct Errors {
    double momentum = 0.0, low_passed = 0.0, apart = 0.0;
  };
  const auto run = [&](double sigma) {
    DisturbanceObserver obs(HyqModel(), Config(), kDt);
    LowPassedResidual old;
    std::mt19937_64 rng(9);
    std::normal_distribution<double> n(0.0, 1.0);
    Errors err;
    for (std::size_t k = 0; k < fl.q.size(); ++k) {
      VectorV v = fl.v[k];
      for (int i = 0; i < dynamics::kNv; ++i) v(i) += sigma * n(rng);
      auto d = Dynamics(fl.q[k], v);
      (void)obs.Update(*d, v, fl.tau[k]);
      const VectorV& e = obs.residual();
      const VectorV& e_old = old.Update(*d, v, fl.tau[k]);
      const VectorV truth = StepResponse(static_cast<int>(k)) * tau_ext;
      err.momentum = std::max(err.momentum, (e - truth).cwiseAbs().maxCoeff());
      err.low_passed = std::max(err.low_passed, (e_old - truth).cwiseAbs().maxCoeff());
      err.apart = std::max(err.apart, (e - e_old).cwiseAbs().maxCoeff());
    }
    return err;
  };
  const Errors exact = run(0.0), noisy = run(0.005);
  std::printf("flight, exact v: momentum observer within %.4f, low-passed residual within %.4f; "
              "apart by %.4f exact, %.4f with 5 mm/s noise on v\n",
              exact.momentum, exact.low_passed, exact.apart, noisy.apart);
  EXPECT_LT(exact.momentum, 0.05 * exact.low_passed);
  // the noise moved both the same way: they stay as far apart as without it
  EXPECT_NEAR(noisy.apart, exact.apart, 0.02);
}

TEST(DisturbanceObserver, ANonFiniteInputHoldsTheEstimateAndRestartsKeepingIt) {
  const Vector6d w = PayloadWrench();
  const AtRest s = StandStill(w);
  DisturbanceObserver obs(HyqModel(), Config(), kDt);
  for (int k = 0; k <= 100; ++k) (void)obs.Update(*s.dyn, VectorV::Zero(), s.tau);
  const Vector6d before = obs.wrench();
  const VectorV r_before = obs.residual();
  dynamics::VectorJ bad = s.tau;
  bad(4) = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(obs.Update(*s.dyn, VectorV::Zero(), bad), before);
    EXPECT_TRUE(obs.held());
    EXPECT_EQ(obs.residual(), r_before);
  }
  VectorV v_bad = VectorV::Zero();
  v_bad(0) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(obs.Update(*s.dyn, v_bad, s.tau), before);
  EXPECT_TRUE(obs.held());
  // the first finite cycle restarts the integral at its momentum, keeping r; then it runs on
  EXPECT_EQ(obs.Update(*s.dyn, VectorV::Zero(), s.tau), before);
  EXPECT_TRUE(obs.held());
  (void)obs.Update(*s.dyn, VectorV::Zero(), s.tau);
  EXPECT_FALSE(obs.held());
  EXPECT_TRUE(testing::NearRel(obs.residual(), (StepResponse(101) * s.tau_ext).eval(), 1e-9));
}

TEST(DisturbanceObserver, AStretchedLegHoldsTheWrenchWhileTheResidualRuns) {
  const AtRest s = StandStill(PayloadWrench());
  DisturbanceObserver obs(HyqModel(), Config(), kDt);
  for (int k = 0; k <= 50; ++k) (void)obs.Update(*s.dyn, VectorV::Zero(), s.tau);
  const Vector6d before = obs.wrench();
  // the lh knee where the contact point is in line with the hip and knee axes: J_leg singular
  constexpr int kLeg = 2;
  VectorQ q = s.q;
  double& knee = q(dynamics::QIndexOfJoint(dynamics::JointIndex(kLeg, 2)));
  const auto det = [&](double angle) {
    knee = angle;
    const auto J = ContactJacobians(*Dynamics(q, VectorV::Zero()))[kLeg];
    return J.middleCols<3>(kNumBaseDofs + 3 * kLeg).determinant();
  };
  double a = -0.6, b = 0.6;
  ASSERT_LT(det(a) * det(b), 0.0);
  for (int i = 0; i < 60; ++i) {
    const double m = 0.5 * (a + b);
    (det(a) * det(m) <= 0.0 ? b : a) = m;
  }
  ASSERT_LT(std::abs(det(a)), 1e-9);
  const auto stretched = Dynamics(q, VectorV::Zero());
  const VectorV r_before = obs.residual();
  EXPECT_EQ(obs.Update(*stretched, VectorV::Zero(), s.tau), before);
  EXPECT_TRUE(obs.held());
  EXPECT_NE(obs.residual(), r_before);
  // the next cycle restarts the projected integral, keeping the estimate; then it runs on
  EXPECT_EQ(obs.Update(*s.dyn, VectorV::Zero(), s.tau), before);
  EXPECT_TRUE(obs.held());
  (void)obs.Update(*s.dyn, VectorV::Zero(), s.tau);
  EXPECT_FALSE(obs.held());
  EXPECT_TRUE(testing::NearRel(obs.wrench(), (StepResponse(51) * PayloadWrench()).eval(), 1e-9));
}

TEST(DisturbanceObserver, TheEstimateIsClampedAndResetForgetsIt) {
  Vector6d w;
  w << 500.0, -800.0, 0.0, 150.0, -20.0, 0.0;
  const AtRest s = StandStill(w);
  DisturbanceObserver obs(HyqModel(), Config(), kDt);
  for (int k = 0; k <= 1000; ++k) (void)obs.Update(*s.dyn, VectorV::Zero(), s.tau);
  EXPECT_DOUBLE_EQ(obs.wrench()(0), 300.0);
  EXPECT_DOUBLE_EQ(obs.wrench()(1), -300.0);
  EXPECT_NEAR(obs.wrench()(2), 0.0, 1e-6);
  EXPECT_DOUBLE_EQ(obs.wrench()(3), 100.0);
  EXPECT_NEAR(obs.wrench()(4), -20.0, 1e-6);
  obs.Reset();
  EXPECT_TRUE(obs.held());
  EXPECT_EQ(obs.wrench(), Vector6d::Zero());
  EXPECT_EQ(obs.residual(), VectorV::Zero());
  (void)obs.Update(*s.dyn, VectorV::Zero(), s.tau);
  (void)obs.Update(*s.dyn, VectorV::Zero(), s.tau);
  EXPECT_TRUE(testing::NearRel(obs.residual(), (StepResponse(1) * s.tau_ext).eval(), 1e-9));
}

TEST(DisturbanceObserver, NoHeapInTheCycle) {
  HYQ_REQUIRE_HEAP_HOOKS();
  const Flight fl = Fly(PayloadWrench(), 40);
  std::vector<std::unique_ptr<CycleDynamics>> dyn;
  for (std::size_t k = 0; k < fl.q.size(); ++k) dyn.push_back(Dynamics(fl.q[k], fl.v[k]));
  DisturbanceObserver obs(HyqModel(), Config(), kDt);
  dynamics::VectorJ bad = fl.tau[0];
  bad(0) = std::numeric_limits<double>::quiet_NaN();
  testing::NoHeapGuard guard;
  for (std::size_t k = 0; k < fl.q.size(); ++k) {
    (void)obs.Update(*dyn[k], fl.v[k], k == 20 ? bad : fl.tau[k]);
    if (k == 30) obs.Reset();
  }
  EXPECT_EQ(guard.allocations(), 0u);
}

}  // namespace
}  // namespace hyq::servo
