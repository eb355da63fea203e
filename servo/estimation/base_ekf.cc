#include "servo/estimation/base_ekf.h"

#include <cmath>

namespace hyq::servo {
namespace {

/// exp([θ]×) as a quaternion.
Eigen::Quaterniond ExpQuaternion(const Eigen::Vector3d& theta) noexcept {
  const double angle = theta.norm();
  if (angle < 1e-12) return Eigen::Quaterniond(1.0, 0.5 * theta.x(), 0.5 * theta.y(), 0.5 * theta.z()).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, theta / angle));
}

}  // namespace

void BaseEkf::Reset(const Eigen::Vector3d& p, const Eigen::Quaterniond& R_WB, double sigma_p_m,
                    double sigma_v_m_s, double sigma_tilt_rad, double sigma_yaw_rad,
                    double sigma_bg_rad_s, double sigma_ba_m_s2) noexcept {
  p_ = p;
  v_.setZero();
  q_ = R_WB.normalized();
  R_ = q_.toRotationMatrix();
  bg_.setZero();
  ba_.setZero();
  P_.setZero();
  P_.block<3, 3>(kP, kP).diagonal().setConstant(sigma_p_m * sigma_p_m);
  P_.block<3, 3>(kV, kV).diagonal().setConstant(sigma_v_m_s * sigma_v_m_s);
  // tilt and yaw are about the world's axes: Σ_θ(B) = Rᵀ diag(σ_tilt², σ_tilt², σ_yaw²) R
  const Eigen::Vector3d s(sigma_tilt_rad * sigma_tilt_rad, sigma_tilt_rad * sigma_tilt_rad,
                          sigma_yaw_rad * sigma_yaw_rad);
  P_.block<3, 3>(kTheta, kTheta) = R_.transpose() * s.asDiagonal() * R_;
  P_.block<3, 3>(kBg, kBg).diagonal().setConstant(sigma_bg_rad_s * sigma_bg_rad_s);
  P_.block<3, 3>(kBa, kBa).diagonal().setConstant(sigma_ba_m_s2 * sigma_ba_m_s2);
}

void BaseEkf::Predict(const Eigen::Vector3d& gyro_B, const Eigen::Vector3d& specific_force_B,
                      const Eigen::Vector3d& gravity_W, const BaseEkfProcessNoise& noise,
                      double dt) noexcept {
  const Eigen::Vector3d w = gyro_B - bg_;
  const Eigen::Vector3d f = specific_force_B - ba_;
  const Eigen::Vector3d a = R_ * f + gravity_W;

  // the error's transition F = I + A dt, applied block by block: P ← F P Fᵀ
  Covariance F = Covariance::Identity();
  F.block<3, 3>(kP, kV).diagonal().setConstant(dt);
  F.block<3, 3>(kV, kTheta) = -R_ * Skew(f) * dt;
  F.block<3, 3>(kV, kBa) = -R_ * dt;
  F.block<3, 3>(kTheta, kTheta) -= Skew(w) * dt;
  F.block<3, 3>(kTheta, kBg).diagonal().setConstant(-dt);
  P_ = (F * P_ * F.transpose()).eval();
  const double qa = noise.accel_m_s2_sqrt_hz * noise.accel_m_s2_sqrt_hz * dt;
  const double qg = noise.gyro_rad_s_sqrt_hz * noise.gyro_rad_s_sqrt_hz * dt;
  const double qbg = noise.gyro_bias_rad_s2_sqrt_hz * noise.gyro_bias_rad_s2_sqrt_hz * dt;
  const double qba = noise.accel_bias_m_s3_sqrt_hz * noise.accel_bias_m_s3_sqrt_hz * dt;
  P_.block<3, 3>(kV, kV).diagonal().array() += qa;  // R σ² I Rᵀ = σ² I
  P_.block<3, 3>(kTheta, kTheta).diagonal().array() += qg;
  P_.block<3, 3>(kBg, kBg).diagonal().array() += qbg;
  P_.block<3, 3>(kBa, kBa).diagonal().array() += qba;

  p_ += v_ * dt + 0.5 * a * dt * dt;
  v_ += a * dt;
  q_ = (q_ * ExpQuaternion(w * dt)).normalized();
  R_ = q_.toRotationMatrix();
}

void BaseEkf::Inject(const ErrorState& dx) noexcept {
  p_ += dx.segment<3>(kP);
  v_ += dx.segment<3>(kV);
  q_ = (q_ * ExpQuaternion(dx.segment<3>(kTheta))).normalized();
  R_ = q_.toRotationMatrix();
  bg_ += dx.segment<3>(kBg);
  ba_ += dx.segment<3>(kBa);
}

bool BaseEkf::finite() const noexcept {
  return p_.allFinite() && v_.allFinite() && q_.coeffs().allFinite() && bg_.allFinite() &&
         ba_.allFinite() && P_.allFinite();
}

}  // namespace hyq::servo
