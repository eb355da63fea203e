#include "servo/estimation/estimator.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace hyq::servo {
namespace {

using Row15 = Eigen::Matrix<double, 1, BaseEkf::kDim>;
using H3 = Eigen::Matrix<double, 3, BaseEkf::kDim>;

}  // namespace

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
    : model_(model), settings_(settings), dt_(dt), legs_(model), R_BI_(model.imu.R_BF),
      p_BI_(model.imu.p_BF_B) {
  Reset();
}

void StateEstimator::Reset() noexcept {
  ekf_.Reset(Eigen::Vector3d(0.0, 0.0, model_.standing_base_height_m), Eigen::Quaterniond::Identity(),
             0.01, settings_.initial_velocity_m_s, settings_.initial_tilt_rad,
             settings_.initial_yaw_rad, settings_.initial_gyro_bias_rad_s,
             settings_.initial_accel_bias_m_s2);
  initialised_ = false;
  still_s_ = 0.0;
  all_rejected_s_ = 0.0;
  have_previous_gyro_ = false;
  qd_lowpass_.setZero();
  w_lowpass_.setZero();
  for (auto& c : contacts_) c = ContactDetector{};
  feet_.fill(FootEstimate{});
  slip_evidence_.fill(false);
  q_ = model_.StandingQ();
  v_.setZero();
  stance_.fill(false);
  load_.fill(0.0);
}

EstimatorStatus StateEstimator::Update(const hal::ProcessImage& image,
                                       const std::array<bool, kNumFeet>& stance_schedule) noexcept {
  // joints: the last valid values (the safety checks decide whether they are fresh enough)
  VectorJ qj, qdj, tau;
  stale_.fill(false);
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto& in = image.joints[static_cast<std::size_t>(j)];
    qj(j) = in.position_rad;
    qdj(j) = in.velocity_rad_s;
    tau(j) = in.torque_Nm;
    if (in.status == hal::InputStatus::kHeld) stale_[static_cast<std::size_t>(j / dynamics::kJointsPerLeg)] = true;
    if (lost_.joint[static_cast<std::size_t>(j)]) {
      if (!std::isfinite(qj(j))) qj(j) = q_(7 + j);
      qdj(j) = 0.0;
      tau(j) = 0.0;
    }
  }
  if (!qj.allFinite() || !qdj.allFinite() || !tau.allFinite()) return EstimatorStatus::kNoJointData;

  const auto& imu = image.imu;
  Eigen::Vector3d gyro_I(imu.gyro_rad_s[0], imu.gyro_rad_s[1], imu.gyro_rad_s[2]);
  Eigen::Vector3d accel_I(imu.accel_m_s2[0], imu.accel_m_s2[1], imu.accel_m_s2[2]);
  if (lost_.imu && initialised_) {
    // without the IMU: not rotating (the gyro reads its bias) and not accelerating (the specific
    // force is gravity's reaction), the lever arm's terms then vanish
    gyro_I = R_BI_.transpose() * ekf_.gyro_bias();
    accel_I = R_BI_.transpose() * (ekf_.R_WB().transpose() * -model_.gravity_W + ekf_.accel_bias());
  }
  if (!gyro_I.allFinite() || !accel_I.allFinite()) return EstimatorStatus::kNoImu;
  const Eigen::Vector3d gyro_B = R_BI_ * gyro_I;
  const Eigen::Vector3d accel_at_imu_B = R_BI_ * accel_I;  // specific force: +g up at rest

  if (!initialised_) {
    // roll and pitch from gravity, yaw 0, height from the model's standing posture until the
    // feet say otherwise
    // (the IMU's centripetal acceleration removed: the robot may be turning)
    const Eigen::Vector3d up = accel_at_imu_B - gyro_B.cross(gyro_B.cross(p_BI_));
    if (up.norm() < 1e-6) return EstimatorStatus::kNoImu;
    Eigen::Quaterniond q0;
    q0.setFromTwoVectors(up.normalized(), Eigen::Vector3d::UnitZ());
    const Eigen::Matrix3d R0 = q0.toRotationMatrix();
    const double yaw = std::atan2(R0(1, 0), R0(0, 0));
    q0 = Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()) * q0;
    ekf_.Reset(Eigen::Vector3d(0.0, 0.0, model_.standing_base_height_m), q0, 0.05,
               settings_.initial_velocity_m_s, settings_.initial_tilt_rad, settings_.initial_yaw_rad,
               settings_.initial_gyro_bias_rad_s, settings_.initial_accel_bias_m_s2);
    initialised_ = true;
  }

  // prediction: the accelerometer's specific force moved from the IMU to the base origin,
  // f_B = f_I − α × p_BI − ω × (ω × p_BI), with α the gyro's difference: summed over the
  // cycles it telescopes to the change of ω, so the lever arm's velocity ω × p_BI is removed
  // exactly however noisy α is (the IMU sits 0.3 m ahead of the base origin: a pitch rate
  // change of 0.3 rad/s would otherwise read as 9 cm/s)
  const Eigen::Vector3d w_pred = gyro_B - ekf_.gyro_bias();
  const Eigen::Vector3d alpha = have_previous_gyro_ ? Eigen::Vector3d((gyro_B - previous_gyro_B_) / dt_)
                                                    : Eigen::Vector3d::Zero();
  previous_gyro_B_ = gyro_B;
  have_previous_gyro_ = true;
  const Eigen::Vector3d f_B = accel_at_imu_B - alpha.cross(p_BI_) - w_pred.cross(w_pred.cross(p_BI_));
  ekf_.Predict(gyro_B, f_B, model_.gravity_W, settings_.process, dt_);

  // feet: kinematics, load (τ + Jᵀ F_on_foot = 0 for a massless leg: F = −J⁻ᵀ τ), contact
  const Eigen::Matrix3d R = ekf_.R_WB();
  for (int leg = 0; leg < kNumFeet; ++leg) {
    const auto l = static_cast<std::size_t>(leg);
    p_BF_[l] = legs_.Foot(leg, qj.segment<3>(3 * leg), &J_[l], nullptr, nullptr, &Jw_[l]);
    const Eigen::Vector3d F_B = -J_[l].transpose().partialPivLu().solve(tau.segment<3>(3 * leg));
    load_[l] = lost_.leg(leg) ? 0.0 : (R * F_B).z();  // a lost leg's foot is no contact
    contacts_[l].Update(load_[l], settings_.contact, dt_);
  }

  CorrectWithFeet(qdj, gyro_B);

  // standing still: zero velocity and zero rate, the biases estimated
  // (the joint rates and the gyro low-passed first: a still robot's sensor noise alone may
  // cross the thresholds)
  const double a = settings_.still_filter_s > dt_ ? dt_ / settings_.still_filter_s : 1.0;
  qd_lowpass_ += a * (qdj - qd_lowpass_);
  w_lowpass_ += a * (gyro_B - ekf_.gyro_bias() - w_lowpass_);
  const bool joints_still = qd_lowpass_.cwiseAbs().maxCoeff() < settings_.still_joint_speed_rad_s;
  const bool not_turning = w_lowpass_.norm() < settings_.still_gyro_rad_s;
  still_s_ = joints_still && not_turning ? still_s_ + dt_ : 0.0;
  if (still()) {
    H3 Hv = H3::Zero();
    Hv.block<3, 3>(0, BaseEkf::kV).setIdentity();
    const double sv = settings_.still_velocity_noise_m_s;
    ekf_.Correct<3>(Hv, -ekf_.velocity(), Eigen::Matrix3d::Identity() * sv * sv, false);
    // y = ω_m − b_g = 0: z = −(ω_m − b̂_g), H = −I on δb_g
    H3 Hw = H3::Zero();
    Hw.block<3, 3>(0, BaseEkf::kBg) = -Eigen::Matrix3d::Identity();
    const double sw = settings_.still_rate_noise_rad_s;
    ekf_.Correct<3>(Hw, -(gyro_B - ekf_.gyro_bias()), Eigen::Matrix3d::Identity() * sw * sw, false);
  }

  // the controllers' stance: scheduled and in contact
  int n = 0;
  for (std::size_t l = 0; l < kNumFeet; ++l) {
    stance_[l] = stance_schedule[l] && contacts_[l].in_contact();
    n += stance_[l] ? 1 : 0;
  }
  if (n == 0) stance_ = stance_schedule;

  q_.head<3>() = ekf_.position();
  const Eigen::Quaterniond& o = ekf_.orientation();
  q_(3) = o.w();
  q_(4) = o.x();
  q_(5) = o.y();
  q_(6) = o.z();
  q_.tail<dynamics::kNumJoints>() = qj;
  v_.head<3>() = ekf_.velocity();
  v_.segment<3>(3) = gyro_B - ekf_.gyro_bias();
  v_.tail<dynamics::kNumJoints>() = qdj;
  if (!ekf_.finite() || !q_.allFinite() || !v_.allFinite()) return EstimatorStatus::kNonFinite;
  return EstimatorStatus::kOk;
}

void StateEstimator::CorrectWithFeet(const VectorJ& qdj, const Eigen::Vector3d& gyro_B) noexcept {
  const double r_min = settings_.min_contact_probability;
  const bool hold_biases = !still();
  // per foot: 0 = v + R u,  u = ω × c + J q̇ + (Jw q̇) × (c − p_F),  c = p_F − r Rᵀ ẑ;
  // H = [0, I, −R [u]×, R [c]×, 0] (δb_g enters through ω = ω_m − b_g)
  const auto foot_measurement = [&](std::size_t l, H3* H, Eigen::Vector3d* z) {
    const Eigen::Matrix3d& R = ekf_.R_WB();
    const Eigen::Vector3d w = gyro_B - ekf_.gyro_bias();
    const Eigen::Vector3d down_r = -model_.feet[l].radius_m * R.row(2).transpose();
    const Eigen::Vector3d c = p_BF_[l] + down_r;
    const Eigen::Vector3d qd = qdj.segment<3>(3 * static_cast<int>(l));
    const Eigen::Vector3d u = w.cross(c) + J_[l] * qd + (Jw_[l] * qd).cross(down_r);
    H->setZero();
    H->block<3, 3>(0, BaseEkf::kV).setIdentity();
    H->block<3, 3>(0, BaseEkf::kTheta) = -R * Skew(u);
    H->block<3, 3>(0, BaseEkf::kBg) = R * Skew(c);
    *z = -(ekf_.velocity() + R * u);
  };
  // a lightly loaded foot holds little tangential force (Coulomb: at most μ F_z) and slides
  // first: its σ grows as firm_contact_force_N / F_z below that load
  const auto foot_noise = [&](std::size_t l) {
    const double light = std::max(1.0, settings_.firm_contact_force_N / std::max(load_[l], 1.0));
    const double s = settings_.leg_velocity_noise_m_s * contacts_[l].noise_scale() * light;
    return Eigen::Matrix3d(Eigen::Matrix3d::Identity() * (s * s / contacts_[l].probability()));
  };

  // gate every foot against the prediction
  std::array<bool, kNumFeet> accept{};
  int candidates = 0, accepted = 0;
  for (std::size_t l = 0; l < kNumFeet; ++l) {
    FootEstimate& f = feet_[l];
    f.contact_probability = contacts_[l].probability();
    f.settling = contacts_[l].settling();
    f.touchdowns = contacts_[l].touchdowns();
    f.used = f.rejected = false;
    f.mahalanobis_sq = 0.0;
    f.contact_velocity_W.setZero();
    H3 H;
    Eigen::Vector3d z;
    foot_measurement(l, &H, &z);
    f.point_velocity_W = -z;
    if (lost_.leg(static_cast<int>(l))) f.contact_probability = 0.0;
    if (stale_[l]) continue;  // a held joint's velocity is old: not this cycle's measurement
    if (f.contact_probability < r_min) continue;
    ++candidates;
    f.contact_velocity_W = -z;
    f.mahalanobis_sq = ekf_.MahalanobisSquared<3>(H, z, foot_noise(l));
    accept[l] = f.mahalanobis_sq <= settings_.gate_chi2;
    accepted += accept[l] ? 1 : 0;
  }
  // the prediction, not the feet, is wrong when every foot disagrees for long: the gate then
  // lets the one foot nearest the prediction through, every cycle until a foot passes it again
  // (not every foot: those still sliding after a landing would drag the estimate with them)
  if (accepted > 0 || candidates == 0) all_rejected_s_ = 0.0;
  else all_rejected_s_ += dt_;
  if (all_rejected_s_ > settings_.max_gated_s) {
    std::size_t best = kNumFeet;
    for (std::size_t l = 0; l < kNumFeet; ++l)
      if (feet_[l].contact_probability >= r_min &&
          (best == kNumFeet || feet_[l].mahalanobis_sq < feet_[best].mahalanobis_sq))
        best = l;
    if (best < kNumFeet) accept[best] = true;
  }
  for (std::size_t l = 0; l < kNumFeet; ++l) {
    FootEstimate& f = feet_[l];
    if (f.contact_probability < r_min) continue;
    if (!accept[l]) {
      f.rejected = true;
      ++f.rejections;
      continue;
    }
    H3 H;
    Eigen::Vector3d z;
    foot_measurement(l, &H, &z);  // after the feet corrected before it
    ekf_.Correct<3>(H, z, foot_noise(l), hold_biases);
    f.used = true;
    // height: the contact point on the ground, z_W(c) = p_z + (R c)_z = ground
    const Eigen::Matrix3d& R = ekf_.R_WB();
    const Eigen::Vector3d c = p_BF_[l] - model_.feet[l].radius_m * R.row(2).transpose();
    Eigen::Matrix<double, 1, BaseEkf::kDim> Hz = Row15::Zero();
    Hz(0, BaseEkf::kP + 2) = 1.0;
    Hz.block<1, 3>(0, BaseEkf::kTheta) = -(R * Skew(c)).row(2);
    const double sz = settings_.height_noise_m * contacts_[l].noise_scale();
    Eigen::Matrix<double, 1, 1> zz, Rz;
    zz(0) = settings_.ground_height_m - (ekf_.position().z() + (R * c).z());
    Rz(0) = sz * sz / f.contact_probability;
    ekf_.Correct<1>(Hz, zz, Rz, hold_biases);
  }

  // slip evidence: a settled foot in contact that does not lift off, the base anchored by
  // another settled accepted foot
  for (std::size_t l = 0; l < kNumFeet; ++l) {
    bool anchored = false;
    for (std::size_t m = 0; m < kNumFeet; ++m)
      anchored = anchored || (m != l && feet_[m].used && !feet_[m].settling);
    // lifting off or bouncing: the contact point rises or falls, or moves faster than a foot
    // slides (at lift-off the swing's torques still read as load on a massless leg, and a
    // bouncing foot's force estimate misses the leg's acceleration)
    const Eigen::Vector3d& vc = feet_[l].contact_velocity_W;
    const bool lifting = std::abs(vc.z()) > settings_.lift_speed_m_s || vc.norm() > settings_.max_slip_speed_m_s;
    slip_evidence_[l] = anchored && feet_[l].contact_probability >= r_min && !feet_[l].settling &&
                        !lifting;
  }
}

Eigen::Vector3d StateEstimator::position_std_m() const noexcept {
  return ekf_.covariance().block<3, 3>(BaseEkf::kP, BaseEkf::kP).diagonal().cwiseSqrt();
}

Eigen::Vector3d StateEstimator::velocity_std_m_s() const noexcept {
  return ekf_.covariance().block<3, 3>(BaseEkf::kV, BaseEkf::kV).diagonal().cwiseSqrt();
}

Eigen::Vector3d StateEstimator::orientation_std_rad() const noexcept {
  const Eigen::Matrix3d& R = ekf_.R_WB();
  const Eigen::Matrix3d S = R * ekf_.covariance().block<3, 3>(BaseEkf::kTheta, BaseEkf::kTheta) * R.transpose();
  return S.diagonal().cwiseSqrt();
}

}  // namespace hyq::servo
