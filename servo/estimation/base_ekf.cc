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

  // the error's transition F = I + A dt has five blocks besides the identity:
  //   F_pv = I dt,  F_vθ = −R [f]× dt,  F_vba = −R dt,  F_θθ = I − [ω]× dt,  F_θbg = −I dt;
  // P ← F P Fᵀ as M = F P (rows), then M Fᵀ (columns), block by block
  const Eigen::Matrix3d A_vt = -R_ * Skew(f) * dt;
  const Eigen::Matrix3d A_vba = -R_ * dt;
  const Eigen::Matrix3d F_tt = Eigen::Matrix3d::Identity() - Skew(w) * dt;
  Covariance& M = scratch_;
  M = P_;
  M.middleRows<3>(kP) += dt * P_.middleRows<3>(kV);
  M.middleRows<3>(kV) += A_vt * P_.middleRows<3>(kTheta) + A_vba * P_.middleRows<3>(kBa);
  M.middleRows<3>(kTheta) = F_tt * P_.middleRows<3>(kTheta) - dt * P_.middleRows<3>(kBg);
  P_ = M;
  P_.middleCols<3>(kP) += dt * M.middleCols<3>(kV);
  P_.middleCols<3>(kV) += M.middleCols<3>(kTheta) * A_vt.transpose() + M.middleCols<3>(kBa) * A_vba.transpose();
  P_.middleCols<3>(kTheta) = M.middleCols<3>(kTheta) * F_tt.transpose() - dt * M.middleCols<3>(kBg);
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
