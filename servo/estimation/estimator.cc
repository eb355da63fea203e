#include "servo/estimation/estimator.h"

#include <cmath>

#include <Eigen/Dense>

namespace hyq::servo {

const char* ToString(EstimatorStatus s) noexcept {
  switch (s) {
    case EstimatorStatus::kOk: return "ok";
    case EstimatorStatus::kNoImu: return "no IMU reading yet";
    case EstimatorStatus::kNoJointData: return "no joint data yet";
    case EstimatorStatus::kNonFinite: return "non-finite estimate";
  }
  return "?";
}

StateEstimator::StateEstimator(const dynamics::Model& model, const EstimatorConfig& settings,
                               double dt)
    : model_(model), settings_(settings), dt_(dt), legs_(model), R_BI_(model.imu.R_BF) {
  Reset();
}

void StateEstimator::Reset() noexcept {
  orientation_.setIdentity();
  p_W_ = Eigen::Vector3d(0.0, 0.0, model_.standing_base_height_m);
  v_W_.setZero();
  initialised_ = false;
  q_ = model_.StandingQ();
  v_.setZero();
  stance_.fill(false);
  load_.fill(0.0);
}

EstimatorStatus StateEstimator::Update(const hal::ProcessImage& image,
                                       const std::array<bool, kNumFeet>& stance_schedule) noexcept {
  // joints: the last valid values (the safety checks decide whether they are fresh enough)
  VectorJ qj, qdj, tau;
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto& in = image.joints[static_cast<std::size_t>(j)];
    qj(j) = in.position_rad;
    qdj(j) = in.velocity_rad_s;
    tau(j) = in.torque_Nm;
  }
  if (!qj.allFinite() || !qdj.allFinite() || !tau.allFinite()) return EstimatorStatus::kNoJointData;

  const auto& imu = image.imu;
  const Eigen::Vector3d gyro_I(imu.gyro_rad_s[0], imu.gyro_rad_s[1], imu.gyro_rad_s[2]);
  const Eigen::Vector3d accel_I(imu.accel_m_s2[0], imu.accel_m_s2[1], imu.accel_m_s2[2]);
  if (!gyro_I.allFinite() || !accel_I.allFinite()) return EstimatorStatus::kNoImu;
  const Eigen::Vector3d w_B = R_BI_ * gyro_I;
  const Eigen::Vector3d f_B = R_BI_ * accel_I;  // specific force: +g up at rest
  const double g = model_.gravity_W.norm();

  if (!initialised_) {
    // roll and pitch from gravity, yaw 0
    if (f_B.norm() < 1e-6) return EstimatorStatus::kNoImu;
    orientation_.setFromTwoVectors(f_B.normalized(), Eigen::Vector3d::UnitZ());
    const Eigen::Matrix3d R = orientation_.toRotationMatrix();
    const double yaw = std::atan2(R(1, 0), R(0, 0));
    orientation_ = Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()) * orientation_;
    initialised_ = true;
  }

  // orientation: gyro + tilt correction (complementary filter)
  Eigen::Vector3d w_corr = w_B;
  const double fn = f_B.norm();
  if (std::abs(fn - g) < settings_.imu_gravity_window_m_s2 && fn > 1e-6) {
    const Eigen::Vector3d up_meas = f_B / fn;
    const Eigen::Vector3d up_pred = orientation_.conjugate() * Eigen::Vector3d::UnitZ();
    w_corr += settings_.tilt_correction_gain * up_meas.cross(up_pred);
  }
  const double angle = w_corr.norm() * dt_;
  if (angle > 1e-12)
    orientation_ = orientation_ * Eigen::Quaterniond(Eigen::AngleAxisd(angle, w_corr.normalized()));
  orientation_.normalize();
  const Eigen::Matrix3d R = orientation_.toRotationMatrix();

  // feet: positions, velocities relative to the base, loads
  std::array<Eigen::Vector3d, kNumFeet> p_BF, v_rel;
  for (int leg = 0; leg < kNumFeet; ++leg) {
    const Eigen::Vector3d ql = qj.segment<3>(3 * leg), qdl = qdj.segment<3>(3 * leg);
    Eigen::Matrix3d J;
    p_BF[static_cast<std::size_t>(leg)] = legs_.Foot(leg, ql, &J);
    v_rel[static_cast<std::size_t>(leg)] = J * qdl;
    // τ + Jᵀ F_on_foot = 0 for a massless leg in equilibrium: F = −J⁻ᵀ τ (base frame)
    const Eigen::Vector3d F_B = -J.transpose().partialPivLu().solve(tau.segment<3>(3 * leg));
    load_[static_cast<std::size_t>(leg)] = (R * F_B).z();
  }
  int n = 0;
  for (int leg = 0; leg < kNumFeet; ++leg) {
    const auto l = static_cast<std::size_t>(leg);
    stance_[l] = stance_schedule[l] && load_[l] > settings_.stance_force_N;
    n += stance_[l] ? 1 : 0;
  }
  if (n == 0) {
    stance_ = stance_schedule;
    for (bool s : stance_) n += s ? 1 : 0;
  }

  // linear velocity and height: IMU prediction corrected by the stance legs
  const Eigen::Vector3d a_W = R * f_B + model_.gravity_W;
  v_W_ += a_W * dt_;
  if (n > 0) {
    Eigen::Vector3d v_kin = Eigen::Vector3d::Zero();
    double z = 0.0;
    for (int leg = 0; leg < kNumFeet; ++leg) {
      const auto l = static_cast<std::size_t>(leg);
      if (!stance_[l]) continue;
      v_kin += -R * (w_B.cross(p_BF[l]) + v_rel[l]);
      z += -(R * p_BF[l]).z() + model_.feet[l].radius_m;
    }
    v_kin /= n;
    z /= n;
    v_W_ += settings_.velocity_blend * (v_kin - v_W_);
    p_W_ += v_W_ * dt_;
    p_W_.z() += settings_.velocity_blend * (z - p_W_.z());
  } else {
    p_W_ += v_W_ * dt_;
  }

  q_.head<3>() = p_W_;
  q_(3) = orientation_.w();
  q_(4) = orientation_.x();
  q_(5) = orientation_.y();
  q_(6) = orientation_.z();
  q_.tail<dynamics::kNumJoints>() = qj;
  v_.head<3>() = v_W_;
  v_.segment<3>(3) = w_B;
  v_.tail<dynamics::kNumJoints>() = qdj;
  if (!q_.allFinite() || !v_.allFinite()) return EstimatorStatus::kNonFinite;
  return EstimatorStatus::kOk;
}

}  // namespace hyq::servo
