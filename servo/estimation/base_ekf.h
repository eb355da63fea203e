// The floating base's error-state extended Kalman filter (docs/estimation.md): the IMU drives
// the prediction, measurements of the base's velocity, height and angular rate correct it.
//
// Nominal state: position p (W), velocity v (W), orientation R_WB (a unit quaternion), gyro
// bias b_g and accelerometer bias b_a (both in the base frame B). Error state (15):
//   δx = [δp, δv, δθ, δb_g, δb_a],  R = R̂ exp([δθ]×)  (δθ in B, a right perturbation).
// Prediction over dt with the gyro's rate ω_m and the accelerometer's specific force f_m (both
// in B, the accelerometer's already moved to the base origin):
//   ω = ω_m − b_g,  f = f_m − b_a,  a = R f + g,
//   p ← p + v dt + ½ a dt²,  v ← v + a dt,  R ← R exp([ω dt]×),
// and the error's Jacobian (Solà, "Quaternion kinematics for the error-state Kalman filter",
// 2017, eqs 268-270 for a right perturbation):
//   δṗ = δv,  δv̇ = −R [f]× δθ − R δb_a − R n_a,  δθ̇ = −[ω]× δθ − δb_g − n_g,
//   δḃ_g = n_bg,  δḃ_a = n_ba,
// discretised to first order (F = I + A dt, Q_d = Q dt) at 1 kHz; F P Fᵀ is formed from F's
// five non-identity 3 × 3 blocks, not as a dense 15 × 15 product (a quarter of the work).
// Corrections: y = h(x) + n with n ~ N(0, Rn); the innovation z = y − h(x̂), S = H P Hᵀ + Rn and
// the squared Mahalanobis distance d² = zᵀ S⁻¹ z (the caller's gate); the gain K = P Hᵀ S⁻¹,
// δx = K z injected into the nominal state, P ← P − K H P − P Hᵀ Kᵀ + K S Kᵀ. With `hold_biases`
// the biases' rows of K are zero ("consider" states, Schmidt 1966): the biases keep their value
// and the covariance stays consistent with the suboptimal gain, which is why the general form of
// the covariance update is used.
//
// Fixed-size matrices only: never allocates or throws.
#pragma once

#include <Eigen/Dense>

#include "dynamics/spatial.h"

namespace hyq::servo {

using dynamics::Skew;

/// Noise of the IMU as the filter's process model sees it (continuous-time densities).
struct BaseEkfProcessNoise {
  double gyro_rad_s_sqrt_hz = 1e-3;         // white gyro noise
  double accel_m_s2_sqrt_hz = 0.01;         // white accelerometer noise and unmodelled accelerations
  double gyro_bias_rad_s2_sqrt_hz = 1e-5;   // random walk of the gyro bias
  double accel_bias_m_s3_sqrt_hz = 1e-4;    // random walk of the accelerometer bias
};

class BaseEkf {
 public:
  static constexpr int kDim = 15;
  static constexpr int kP = 0, kV = 3, kTheta = 6, kBg = 9, kBa = 12;  // blocks of δx
  using Covariance = Eigen::Matrix<double, kDim, kDim>;
  using ErrorState = Eigen::Matrix<double, kDim, 1>;

  /// Starts at (p, v = 0, R, zero biases) with the covariance diag(σ²) per block.
  void Reset(const Eigen::Vector3d& p, const Eigen::Quaterniond& R_WB, double sigma_p_m,
             double sigma_v_m_s, double sigma_tilt_rad, double sigma_yaw_rad, double sigma_bg_rad_s,
             double sigma_ba_m_s2) noexcept;

  /// One step of the process model with the base-frame gyro rate and specific force.
  void Predict(const Eigen::Vector3d& gyro_B, const Eigen::Vector3d& specific_force_B,
               const Eigen::Vector3d& gravity_W, const BaseEkfProcessNoise& noise, double dt) noexcept;

  /// Innovation statistics of an M-dimensional measurement (nothing changes).
  template <int M>
  double MahalanobisSquared(const Eigen::Matrix<double, M, kDim>& H, const Eigen::Matrix<double, M, 1>& z,
                            const Eigen::Matrix<double, M, M>& Rn) const noexcept {
    const Eigen::Matrix<double, M, M> S = H * P_ * H.transpose() + Rn;
    return z.dot(S.inverse() * z);  // closed form for M ≤ 4; S is SPD
  }

  /// Corrects the state with innovation z = y − h(x̂) of a measurement with Jacobian H.
  template <int M>
  void Correct(const Eigen::Matrix<double, M, kDim>& H, const Eigen::Matrix<double, M, 1>& z,
               const Eigen::Matrix<double, M, M>& Rn, bool hold_biases) noexcept {
    const Eigen::Matrix<double, kDim, M> PHt = P_ * H.transpose();
    const Eigen::Matrix<double, M, M> S = H * PHt + Rn;
    Eigen::Matrix<double, kDim, M> K = PHt * S.inverse();
    if (hold_biases) K.template bottomRows<6>().setZero();
    const Eigen::Matrix<double, kDim, M> KS = K * S;
    P_ -= K * PHt.transpose() + PHt * K.transpose() - KS * K.transpose();
    P_ = 0.5 * (P_ + P_.transpose()).eval();
    Inject(K * z);
  }

  const Eigen::Vector3d& position() const noexcept { return p_; }
  const Eigen::Vector3d& velocity() const noexcept { return v_; }
  const Eigen::Quaterniond& orientation() const noexcept { return q_; }
  const Eigen::Matrix3d& R_WB() const noexcept { return R_; }
  const Eigen::Vector3d& gyro_bias() const noexcept { return bg_; }
  const Eigen::Vector3d& accel_bias() const noexcept { return ba_; }
  const Covariance& covariance() const noexcept { return P_; }
  bool finite() const noexcept;

 private:
  void Inject(const ErrorState& dx) noexcept;

  Eigen::Vector3d p_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d bg_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d ba_ = Eigen::Vector3d::Zero();
  Covariance P_ = Covariance::Identity();
  Covariance scratch_ = Covariance::Zero();  // Predict's F P
};


}  // namespace hyq::servo
