// The state estimator (servo/estimation/estimator.h) on synthetic motions whose answer is known
// in closed form: the IMU's readings and the legs' joint angles, rates and torques are made
// from a prescribed base motion and still (or slipping) contact points, exactly as the sensors
// would report them, and the estimate is compared with the motion.
#include <array>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "dynamics/leg_kinematics.h"
#include "dynamics/spatial.h"
#include "servo/estimation/base_ekf.h"
#include "servo/estimation/contact_detector.h"
#include "servo/estimation/estimator.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::servo {
namespace {

using testing::HyqModel;
constexpr double kDt = 1e-3;
constexpr std::array<bool, kNumFeet> kAll{true, true, true, true};

/// A prescribed world: the base's motion, per foot a load and the world velocity of its
/// contact point (zero: sticking). Produces the process image the sensors would.
class SyntheticRobot {
 public:
  SyntheticRobot() : model_(HyqModel()), legs_(model_) {
    p_ = Eigen::Vector3d(0.0, 0.0, model_.standing_base_height_m);
    const dynamics::VectorQ q0 = model_.StandingQ();
    qj_ = q0.tail<dynamics::kNumJoints>();
    load_.fill(200.0);
    for (auto& s : slip_W) s.setZero();  // Eigen leaves its vectors uninitialised
  }

  // the base's motion: linear acceleration (W), angular velocity (B, constant)
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_B = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  std::array<Eigen::Vector3d, kNumFeet> slip_W{};  // contact point's world velocity
  Eigen::Vector3d gyro_bias_I = Eigen::Vector3d::Zero();

  void SetLoad(int foot, double load_N) { load_[static_cast<std::size_t>(foot)] = load_N; }

  /// The sensors' readings now, then the world advances by dt.
  hal::ProcessImage Step() {
    hal::ProcessImage image;
    const Eigen::Matrix3d R = R_.toRotationMatrix();
    const Eigen::Matrix3d R_BI = model_.imu.R_BF;
    const Eigen::Vector3d r = model_.imu.p_BF_B;
    // IMU: specific force at the IMU, Rᵀ(a − g) + ω × (ω × r) (α = 0)
    const Eigen::Vector3d f_B = R.transpose() * (a_W - model_.gravity_W) + w_B.cross(w_B.cross(r));
    const Eigen::Vector3d gyro_I = R_BI.transpose() * w_B + gyro_bias_I;
    const Eigen::Vector3d accel_I = R_BI.transpose() * f_B;
    for (int i = 0; i < 3; ++i) {
      image.imu.gyro_rad_s[static_cast<std::size_t>(i)] = gyro_I(i);
      image.imu.accel_m_s2[static_cast<std::size_t>(i)] = accel_I(i);
    }
    image.imu.status = hal::InputStatus::kValid;
    // legs: q̇ so that the contact point moves at slip_W: v + R(ω × c + J q̇ + (Jw q̇) × d) = slip
    for (int leg = 0; leg < kNumFeet; ++leg) {
      const auto l = static_cast<std::size_t>(leg);
      Eigen::Matrix3d J, Jw;
      const Eigen::Vector3d ql = qj_.segment<3>(3 * leg);
      const Eigen::Vector3d p_F = legs_.Foot(leg, ql, &J, nullptr, nullptr, &Jw);
      const Eigen::Vector3d d = -model_.feet[l].radius_m * R.row(2).transpose();
      const Eigen::Vector3d c = p_F + d;
      const Eigen::Matrix3d A = J - Skew(d) * Jw;
      const Eigen::Vector3d qd = A.inverse() * (R.transpose() * (slip_W[l] - v_W) - w_B.cross(c));
      // load cells: the ground's force (0, 0, load) in W on a massless leg, τ = −Jᵀ F_B
      const Eigen::Vector3d F_B = R.transpose() * Eigen::Vector3d(0.0, 0.0, load_[l]);
      const Eigen::Vector3d tau = -J.transpose() * F_B;
      for (int k = 0; k < 3; ++k) {
        auto& in = image.joints[static_cast<std::size_t>(3 * leg + k)];
        in.position_rad = ql(k);
        in.velocity_rad_s = qd(k);
        in.torque_Nm = tau(k);
        in.status = hal::InputStatus::kValid;
      }
      qj_.segment<3>(3 * leg) += qd * kDt;
    }
    p_ += v_W * kDt + 0.5 * a_W * kDt * kDt;
    v_W += a_W * kDt;
    R_ = (R_ * Eigen::Quaterniond(Eigen::AngleAxisd(w_B.norm() * kDt,
                                                    w_B.norm() > 0 ? w_B.normalized() : Eigen::Vector3d::UnitZ())))
             .normalized();
    return image;
  }

  const Eigen::Vector3d& position() const { return p_; }
  Eigen::Matrix3d R_WB() const { return R_.toRotationMatrix(); }
  const dynamics::Model& model() const { return model_; }

 private:
  const dynamics::Model& model_;
  dynamics::LegKinematics legs_;
  Eigen::Vector3d p_;
  Eigen::Quaterniond R_ = Eigen::Quaterniond::Identity();
  dynamics::VectorJ qj_;
  std::array<double, kNumFeet> load_{};
};

double Yaw(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

TEST(StateEstimator, StandingStillStaysStillAtTheRightHeight) {
  SyntheticRobot robot;
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  for (int i = 0; i < 2000; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  EXPECT_LT(est.v().head<3>().norm(), 1e-4);
  EXPECT_NEAR(est.q()(2), robot.position().z(), 1e-3);
  EXPECT_TRUE(est.still());
  for (const FootEstimate& f : est.feet()) {
    EXPECT_TRUE(f.used);
    EXPECT_EQ(f.rejections, 0);
  }
}

// a pure rotation about the vertical in the air: yaw integrates the gyro, and the IMU's lever
// arm (it sits 0.29 m ahead of the base origin, so it feels ω²r) does not leak into velocity
TEST(StateEstimator, PureRotationIntegratesYawAndLeavesVelocityAlone) {
  SyntheticRobot robot;
  for (int f = 0; f < kNumFeet; ++f) robot.SetLoad(f, 0.0);
  robot.w_B = Eigen::Vector3d(0.0, 0.0, 0.8);
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  EXPECT_NEAR(Yaw(est.R_WB()), Yaw(robot.R_WB()), 1e-6);
  EXPECT_NEAR(Yaw(est.R_WB()), 0.8, 1e-3);
  EXPECT_LT(est.v().head<3>().norm(), 1e-6);
  EXPECT_NEAR(est.v()(5), 0.8, 1e-9);
  for (const FootEstimate& f : est.feet()) {
    EXPECT_LT(f.contact_probability, 0.01);
    EXPECT_FALSE(f.used);
  }
}

// constant acceleration with no foot on the ground: v = a t, p = p0 + ½ a t² (the filter
// starts on a still robot: its tilt comes from gravity)
TEST(StateEstimator, ConstantAccelerationIntegrates) {
  SyntheticRobot robot;
  for (int f = 0; f < kNumFeet; ++f) robot.SetLoad(f, 0.0);
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  robot.a_W = Eigen::Vector3d(0.5, -0.2, 0.1);
  const Eigen::Vector3d p0 = robot.position();
  const Eigen::Vector3d p0_est = est.q().head<3>();
  for (int i = 0; i < 500; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  const double t = 0.5;
  EXPECT_LT((est.v().head<3>() - robot.a_W * t).norm(), 1e-3);
  EXPECT_LT((est.q().head<3>() - p0_est - 0.5 * robot.a_W * t * t).norm(), 1e-3);
  EXPECT_LT((robot.position() - p0 - 0.5 * robot.a_W * t * t).norm(), 1e-9);  // the world itself
}

// a gyro bias is learned while the robot stands still, yaw included (the zero-rate update
// makes it observable), and yaw then stops drifting
TEST(StateEstimator, GyroBiasConvergesWhileStandingAndYawStopsDrifting) {
  SyntheticRobot robot;
  robot.gyro_bias_I = Eigen::Vector3d(0.0035, -0.002, 0.003);
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  for (int i = 0; i < 5000; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  const Eigen::Vector3d bias_B = robot.model().imu.R_BF * robot.gyro_bias_I;
  EXPECT_LT((est.gyro_bias_rad_s() - bias_B).norm(), 0.05 * bias_B.norm())
      << est.gyro_bias_rad_s().transpose() << " vs " << bias_B.transpose();
  const double yaw5 = Yaw(est.R_WB());
  for (int i = 0; i < 5000; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  EXPECT_LT(std::abs(Yaw(est.R_WB()) - yaw5), 1e-3);  // 5 s more
  EXPECT_LT(std::abs(yaw5), 0.0035 * 5.0);  // less than the bias alone would have turned it
}

// moving: the biases are held (impacts and slips would pull them), standing: estimated
TEST(StateEstimator, BiasesHeldWhileMoving) {
  SyntheticRobot robot;
  robot.v_W = Eigen::Vector3d(0.3, 0.0, 0.0);
  robot.gyro_bias_I = Eigen::Vector3d(0.0, 0.0, 0.01);
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  for (int i = 0; i < 500; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  EXPECT_FALSE(est.still());
  EXPECT_EQ(est.gyro_bias_rad_s(), Eigen::Vector3d::Zero());
  EXPECT_EQ(est.accel_bias_m_s2(), Eigen::Vector3d::Zero());
}

// walking at 0.3 m/s on two diagonal feet, one foot starts to slip at 0.2 m/s: it is rejected
// and counted, and the estimate stays with the other foot and the IMU
TEST(StateEstimator, SlippingFootIsRejectedAndCounted) {
  SyntheticRobot robot;
  robot.v_W = Eigen::Vector3d(0.3, 0.0, 0.0);
  robot.SetLoad(1, 0.0);  // rf and lh in the air
  robot.SetLoad(2, 0.0);
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  for (int i = 0; i < 300; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  EXPECT_LT((est.v().head<3>() - robot.v_W).norm(), 2e-3);
  robot.slip_W[0] = Eigen::Vector3d(0.2, 0.05, 0.0);  // lf slips
  double worst = 0.0;
  for (int i = 0; i < 100; ++i) {
    ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
    worst = std::max(worst, (est.v().head<3>() - robot.v_W).norm());
  }
  EXPECT_LT(worst, 0.01);
  EXPECT_TRUE(est.feet()[0].rejected);
  EXPECT_GE(est.feet()[0].rejections, 90);
  EXPECT_EQ(est.feet()[3].rejections, 0);
  EXPECT_TRUE(est.feet()[3].used);
  // the slipping foot's slip is evidence (the base is anchored by rh); rh's is not (nothing
  // but itself anchors the base against which it would be measured)
  EXPECT_TRUE(est.slip_evidence()[0]);
  EXPECT_FALSE(est.slip_evidence()[3]);
}

// every foot in contact disagrees with the prediction for longer than max_gated_s: the
// prediction was wrong, the gate opens and the feet bring the estimate back
TEST(StateEstimator, GateOpensWhenEveryFootDisagreesForLong) {
  SyntheticRobot robot;
  EstimatorConfig cfg;
  StateEstimator est(robot.model(), cfg, kDt);
  for (int i = 0; i < 300; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  // all four feet report a 0.5 m/s base velocity the IMU never saw (e.g. after a reset in motion)
  robot.v_W = Eigen::Vector3d(0.5, 0.0, 0.0);
  for (int i = 0; i < 400; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  EXPECT_LT((est.v().head<3>() - robot.v_W).norm(), 0.01);
}

// a foot lands while still moving (a bounce: 0.3 m/s falling to zero over 30 ms): with the
// touchdown's distrust and the gate the estimate does not spike
TEST(StateEstimator, BouncingFootAtTouchdownDoesNotSpikeTheEstimate) {
  SyntheticRobot robot;
  robot.v_W = Eigen::Vector3d(0.3, 0.0, 0.0);
  robot.SetLoad(1, 0.0);
  robot.SetLoad(2, 0.0);
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  for (int i = 0; i < 300; ++i) ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
  robot.SetLoad(1, 250.0);  // rf lands
  double worst = 0.0;
  for (int i = 0; i < 100; ++i) {
    const double k = std::max(0.0, 1.0 - i / 30.0);
    robot.slip_W[1] = Eigen::Vector3d(0.3 * k, 0.1 * k, -0.2 * k);
    ASSERT_EQ(est.Update(robot.Step(), kAll), EstimatorStatus::kOk);
    worst = std::max(worst, (est.v().head<3>() - robot.v_W).norm());
    if (i == 0) {
      EXPECT_TRUE(est.feet()[1].settling);
    }
  }
  EXPECT_LT(worst, 0.01);
  EXPECT_TRUE(est.feet()[1].used);  // settled, it is trusted again
  EXPECT_EQ(est.feet()[1].touchdowns, 1);
}

TEST(StateEstimator, ControllersStanceIsScheduledAndInContact) {
  SyntheticRobot robot;
  robot.SetLoad(2, 0.0);
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  ASSERT_EQ(est.Update(robot.Step(), {true, false, true, true}), EstimatorStatus::kOk);
  EXPECT_EQ(est.stance(), (std::array<bool, kNumFeet>{true, false, false, true}));
  // no foot both scheduled and in contact: the schedule
  ASSERT_EQ(est.Update(robot.Step(), {false, false, true, false}), EstimatorStatus::kOk);
  EXPECT_EQ(est.stance(), (std::array<bool, kNumFeet>{false, false, true, false}));
}

TEST(StateEstimator, MissingInputsAreReportedNotEstimated) {
  SyntheticRobot robot;
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  hal::ProcessImage image = robot.Step();
  image.imu.gyro_rad_s[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(est.Update(image, kAll), EstimatorStatus::kNoImu);
  image = robot.Step();
  image.joints[4].torque_Nm = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(est.Update(image, kAll), EstimatorStatus::kNoJointData);
  EXPECT_FALSE(est.initialised());
}

TEST(StateEstimator, AllocatesNothingPerCycle) {
  SyntheticRobot robot;
  robot.v_W = Eigen::Vector3d(0.2, 0.0, 0.0);
  StateEstimator est(robot.model(), EstimatorConfig{}, kDt);
  std::array<hal::ProcessImage, 600> images;
  for (int i = 0; i < 600; ++i) {
    if (i == 200) robot.slip_W[0] = Eigen::Vector3d(0.3, 0.0, 0.0);  // rejections
    if (i == 300) robot.SetLoad(1, 0.0);                               // contact changes
    images[static_cast<std::size_t>(i)] = robot.Step();
  }
  ASSERT_EQ(est.Update(images[0], kAll), EstimatorStatus::kOk);
  testing::NoHeapGuard guard;
  for (std::size_t i = 1; i < images.size(); ++i) (void)est.Update(images[i], kAll);
  EXPECT_EQ(guard.allocations(), 0u);
}

// --- the parts --------------------------------------------------------------------------

TEST(ContactDetector, ProbabilityIsLogisticInTheLoadAndTouchdownsAreCounted) {
  ContactDetectorConfig c;
  c.force_N = 60.0;
  c.width_N = 10.0;
  c.touchdown_window_s = 0.04;
  c.touchdown_noise_scale = 5.0;
  ContactDetector d;
  d.Update(60.0, c, kDt);
  EXPECT_DOUBLE_EQ(d.probability(), 0.5);
  EXPECT_TRUE(d.in_contact());
  EXPECT_EQ(d.touchdowns(), 1);
  EXPECT_DOUBLE_EQ(d.noise_scale(), 5.0);
  EXPECT_TRUE(d.settling());
  d.Update(80.0, c, kDt);
  EXPECT_NEAR(d.probability(), 1.0 / (1.0 + std::exp(-2.0)), 1e-12);
  EXPECT_NEAR(d.noise_scale(), 1.0 + 4.0 * (1.0 - 0.001 / 0.04), 1e-12);
  for (int i = 0; i < 40; ++i) d.Update(300.0, c, kDt);
  EXPECT_FALSE(d.settling());
  EXPECT_DOUBLE_EQ(d.noise_scale(), 1.0);
  d.Update(0.0, c, kDt);
  EXPECT_FALSE(d.in_contact());
  d.Update(300.0, c, kDt);
  EXPECT_EQ(d.touchdowns(), 2);
  d.Update(std::numeric_limits<double>::quiet_NaN(), c, kDt);
  EXPECT_EQ(d.probability(), 0.0);
}

// the filter's correction against the textbook formulas, and the held biases
TEST(BaseEkf, CorrectionIsTheKalmanUpdateAndHeldBiasesStayPut) {
  BaseEkf ekf;
  ekf.Reset(Eigen::Vector3d(0, 0, 0.6), Eigen::Quaterniond::Identity(), 0.1, 0.2, 0.05, 0.1, 0.01, 0.1);
  ekf.Predict(Eigen::Vector3d(0.01, 0.02, 0.0), Eigen::Vector3d(0.1, 0.0, 9.81), Eigen::Vector3d(0, 0, -9.81),
              BaseEkfProcessNoise{}, kDt);
  Eigen::Matrix<double, 3, BaseEkf::kDim> H = Eigen::Matrix<double, 3, BaseEkf::kDim>::Zero();
  H.block<3, 3>(0, BaseEkf::kV).setIdentity();
  H.block<3, 3>(0, BaseEkf::kBg) = Skew(Eigen::Vector3d(0.3, 0.2, -0.5));
  const Eigen::Vector3d z(0.05, -0.02, 0.01);
  const Eigen::Matrix3d Rn = Eigen::Matrix3d::Identity() * 1e-4;
  const BaseEkf::Covariance P = ekf.covariance();
  const Eigen::Matrix3d S = H * P * H.transpose() + Rn;
  EXPECT_NEAR(ekf.MahalanobisSquared<3>(H, z, Rn), z.dot(S.inverse() * z), 1e-9);
  BaseEkf held = ekf;
  ekf.Correct<3>(H, z, Rn, false);
  const Eigen::Matrix<double, BaseEkf::kDim, 3> K = P * H.transpose() * S.inverse();
  const BaseEkf::Covariance P_expected = (BaseEkf::Covariance::Identity() - K * H) * P;
  EXPECT_LT((ekf.covariance() - P_expected).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NE(ekf.gyro_bias(), Eigen::Vector3d::Zero());
  held.Correct<3>(H, z, Rn, true);
  EXPECT_EQ(held.gyro_bias(), Eigen::Vector3d::Zero());
  EXPECT_EQ(held.accel_bias(), Eigen::Vector3d::Zero());
  // the held update's covariance is the Joseph form with the biases' gain rows zero
  Eigen::Matrix<double, BaseEkf::kDim, 3> Kh = K;
  Kh.bottomRows<6>().setZero();
  const BaseEkf::Covariance IKH = BaseEkf::Covariance::Identity() - Kh * H;
  const BaseEkf::Covariance P_joseph = IKH * P * IKH.transpose() + Kh * Rn * Kh.transpose();
  EXPECT_LT((held.covariance() - P_joseph).cwiseAbs().maxCoeff(), 1e-12);
}

// the prediction's covariance against the dense first-order transition F P Fᵀ + Q dt built here
// from the error dynamics (Solà 2017), on a covariance with every block correlated
TEST(BaseEkf, PredictionIsTheDenseTransition) {
  BaseEkf ekf;
  ekf.Reset(Eigen::Vector3d(0.1, -0.2, 0.6), Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
            0.1, 0.2, 0.05, 0.1, 0.01, 0.1);
  // correlate everything: a few corrections through random measurement Jacobians
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 4; ++k) {
    Eigen::Matrix<double, 3, BaseEkf::kDim> H;
    for (int i = 0; i < H.size(); ++i) H(i) = n(rng);
    ekf.Correct<3>(H, Eigen::Vector3d(n(rng), n(rng), n(rng)) * 1e-3, Eigen::Matrix3d::Identity() * 1e-2, false);
  }
  const BaseEkf::Covariance P = ekf.covariance();
  const Eigen::Matrix3d R = ekf.R_WB();
  const Eigen::Vector3d gyro(0.4, -0.3, 0.8), force(0.7, -0.4, 9.6);
  const BaseEkfProcessNoise q{2e-3, 0.05, 1e-4, 1e-3};
  const double dt = 1e-3;
  const Eigen::Vector3d w = gyro - ekf.gyro_bias(), f = force - ekf.accel_bias();
  BaseEkf::Covariance F = BaseEkf::Covariance::Identity();
  F.block<3, 3>(BaseEkf::kP, BaseEkf::kV) = Eigen::Matrix3d::Identity() * dt;
  F.block<3, 3>(BaseEkf::kV, BaseEkf::kTheta) = -R * dynamics::Skew(f) * dt;
  F.block<3, 3>(BaseEkf::kV, BaseEkf::kBa) = -R * dt;
  F.block<3, 3>(BaseEkf::kTheta, BaseEkf::kTheta) -= dynamics::Skew(w) * dt;
  F.block<3, 3>(BaseEkf::kTheta, BaseEkf::kBg) = -Eigen::Matrix3d::Identity() * dt;
  Eigen::Matrix<double, BaseEkf::kDim, 1> Qd;
  Qd << Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(q.accel_m_s2_sqrt_hz * q.accel_m_s2_sqrt_hz * dt),
      Eigen::Vector3d::Constant(q.gyro_rad_s_sqrt_hz * q.gyro_rad_s_sqrt_hz * dt),
      Eigen::Vector3d::Constant(q.gyro_bias_rad_s2_sqrt_hz * q.gyro_bias_rad_s2_sqrt_hz * dt),
      Eigen::Vector3d::Constant(q.accel_bias_m_s3_sqrt_hz * q.accel_bias_m_s3_sqrt_hz * dt);
  const BaseEkf::Covariance expected = F * P * F.transpose() + BaseEkf::Covariance(Qd.asDiagonal());
  ekf.Predict(gyro, force, Eigen::Vector3d(0, 0, -9.81), q, dt);
  EXPECT_LT((ekf.covariance() - expected).cwiseAbs().maxCoeff(), 1e-15 * P.cwiseAbs().maxCoeff() + 1e-18);
}

}  // namespace
}  // namespace hyq::servo
