#include "sim/hydraulic_actuator.h"

#include <algorithm>
#include <cmath>

namespace hyq::sim {
namespace {

// √Δp of (2), made linear below Δp_lam (same value and a finite slope there), odd in Δp
double Root(double dp, double lam) noexcept {
  const double a = std::abs(dp);
  const double r = a >= lam ? std::sqrt(a) : a / std::sqrt(lam);
  return dp >= 0 ? r : -r;
}
double RootSlope(double dp, double lam) noexcept {
  const double a = std::abs(dp);
  return a >= lam ? 0.5 / std::sqrt(a) : 1.0 / std::sqrt(lam);
}

void Require(bool ok, const std::string& joint, const std::string& what, double found) {
  if (!ok)
    throw std::invalid_argument("hydraulic actuator " + joint + ": expected " + what + ", found " +
                                std::to_string(found));
}

}  // namespace

HydraulicActuator::HydraulicActuator(const HydraulicParams& p, const hal::JointCalibration& cal,
                                     double q_min_rad, double q_max_rad, double plant_step_s,
                                     const std::string& joint)
    : p_(p), cal_(cal), rotary_(cal.kind == hal::ActuatorKind::kRotary) {
  Require(p.supply_pressure_Pa > p.return_pressure_Pa, joint, "supply pressure > return pressure",
          p.supply_pressure_Pa);
  Require(p.return_pressure_Pa >= 0, joint, "return pressure >= 0", p.return_pressure_Pa);
  Require(p.bulk_modulus_Pa > 0, joint, "bulk modulus > 0", p.bulk_modulus_Pa);
  Require(p.valve_bandwidth_hz > 0, joint, "valve bandwidth > 0", p.valve_bandwidth_hz);
  Require(p.valve_damping > 0, joint, "valve damping > 0", p.valve_damping);
  Require(p.valve_rated_flow_m3_s > 0 && p.valve_rated_drop_Pa > 0, joint, "rated flow and drop > 0",
          p.valve_rated_flow_m3_s);
  Require(p.laminar_drop_Pa > 0, joint, "laminar drop > 0", p.laminar_drop_Pa);
  Require(p.dead_volume_m3 > 0, joint, "dead volume > 0", p.dead_volume_m3);
  Require(p.substeps >= 1, joint, "substeps >= 1", p.substeps);
  Require(q_max_rad > q_min_rad, joint, "q_max > q_min", q_max_rad - q_min_rad);
  Require(plant_step_s > 0, joint, "plant step > 0", plant_step_s);
  h_ = plant_step_s / p.substeps;
  loops_ = std::max(1, static_cast<int>(std::lround(plant_step_s * p.loop_rate_hz)));
  Require(p.substeps % loops_ == 0, joint, "substeps a multiple of the torque loop's updates per step",
          p.substeps);
  substeps_per_loop_ = p.substeps / loops_;
  // the valve is rated with Δp_n over both lands, i.e. Δp_n / 2 across each orifice
  k_orifice_ = p.valve_rated_flow_m3_s / std::sqrt(0.5 * p.valve_rated_drop_Pa);
  Require(p.valve_radial_clearance_m > 0 && p.valve_port_width_m > 0 && p.oil_viscosity_Pa_s > 0,
          joint, "valve radial clearance, port width and oil viscosity > 0", p.valve_radial_clearance_m);
  g_leak_ = M_PI * p.valve_radial_clearance_m * p.valve_radial_clearance_m * p.valve_port_width_m /
            (32.0 * p.oil_viscosity_Pa_s);
  if (rotary_) {
    Require(p.rotary_displacement_m3_rad > 0, joint, "rotary displacement > 0", p.rotary_displacement_m3_rad);
    area_a_ = area_b_ = p.rotary_displacement_m3_rad;
    len_min_ = q_min_rad - p.rotary_margin_rad;
    len_max_ = q_max_rad + p.rotary_margin_rad;
    kp_ = p.rotary_kp_per_Nm;
    ki_ = p.rotary_ki_per_Nm_s;
    f_c_ = p.rotary_seal_coulomb_Nm;
    b_ = p.rotary_seal_viscous_Nm_s;
    v_s_ = p.rotary_seal_band_rad_s;
  } else {
    Require(p.piston_diameter_m > p.rod_diameter_m && p.rod_diameter_m >= 0, joint,
            "piston diameter > rod diameter >= 0", p.piston_diameter_m);
    area_a_ = M_PI / 4 * p.piston_diameter_m * p.piston_diameter_m;
    area_b_ = area_a_ - M_PI / 4 * p.rod_diameter_m * p.rod_diameter_m;
    // L(q) over the joint range (monotonic where the lever arm keeps its sign, which the HAL
    // checks: hal::ValidateCalibration)
    const double l0 = hal::CylinderLength(cal.cylinder, q_min_rad);
    const double l1 = hal::CylinderLength(cal.cylinder, q_max_rad);
    len_min_ = std::min(l0, l1) - p.stroke_margin_m;
    len_max_ = std::max(l0, l1) + p.stroke_margin_m;
    kp_ = p.cylinder_kp_per_N;
    ki_ = p.cylinder_ki_per_N_s;
    f_c_ = p.seal_coulomb_N;
    b_ = p.seal_viscous_N_s_m;
    v_s_ = p.seal_band_m_s;
  }
  Require(kp_ >= 0 && ki_ >= 0, joint, "torque-loop gains >= 0", kp_);
  Require(v_s_ > 0, joint, "seal friction velocity band > 0", v_s_);
  Reset(0.5 * (q_min_rad + q_max_rad), 0.0);
}

double HydraulicActuator::Length(double q) const noexcept {
  return rotary_ ? q : hal::CylinderLength(cal_.cylinder, q);
}

double HydraulicActuator::Lever(double q) const noexcept {
  return rotary_ ? 1.0 : hal::LeverArm(cal_.cylinder, q);
}

double HydraulicActuator::LockDamping(double q) const noexcept {
  const double r = Lever(q);
  return r * r * (area_a_ * area_a_ + area_b_ * area_b_) / (2.0 * g_leak_);
}

double HydraulicActuator::LockTorqueLimitNm(double q) const noexcept {
  return kReliefRatio * p_.supply_pressure_Pa * std::max(area_a_, area_b_) * std::abs(Lever(q));
}

double HydraulicActuator::MaxTorqueNm(double q, bool positive) const noexcept {
  const double dp = p_.supply_pressure_Pa - p_.return_pressure_Pa;
  const double r = Lever(q);
  // pushing (F > 0) uses the piston side, pulling the rod side
  const bool push = positive == (r > 0);
  return std::abs(r) * (push ? area_a_ : area_b_) * dp;
}

void HydraulicActuator::Reset(double q, double tau) noexcept {
  const double r = Lever(q);
  const double force = r != 0 ? tau / r : 0.0;
  // the rod side at mid-pressure, the piston side carrying the force
  const double mid = 0.5 * (p_.supply_pressure_Pa + p_.return_pressure_Pa);
  pb_ = mid;
  pa_ = std::clamp((force + pb_ * area_b_) / area_a_, p_.return_pressure_Pa, p_.supply_pressure_Pa);
  x_ = xd_ = integral_ = 0.0;
  force_ = pa_ * area_a_ - pb_ * area_b_;
  tau_Nm_ = force_ * r;
}

double HydraulicActuator::Step(double tau_ref, double q0, double qd, bool outputs_on) noexcept {
  const double ps = p_.supply_pressure_Pa, pr = p_.return_pressure_Pa, lam = p_.laminar_drop_Pa;
  const double w = 2 * M_PI * p_.valve_bandwidth_hz, z = p_.valve_damping;
  const double p_max = kReliefRatio * ps;  // the relief valve
  const double loop_dt = h_ * substeps_per_loop_;
  double tau_sum = 0.0;
  double t = 0.0;
  for (int l = 0; l < loops_; ++l) {
    // the board: samples the load cell and the encoder, computes u (5), holds it
    const double q = q0 + qd * t;
    const double r = Lever(q);
    double u = 0.0;  // outputs off: no current, the spool's springs centre it
    if (!outputs_on) integral_ = 0.0;
    if (outputs_on && r != 0) {
      const double e = tau_ref / r - force_;
      const double ldot = r * qd;
      // velocity compensation (6): the opening whose two flows leave the rod force unchanged
      // by the motion, at the chambers' present pressure drops and volumes (the boards read
      // both chamber pressures)
      double u_ff = 0.0;
      if (p_.velocity_compensation) {
        const double len = Length(q);
        const double va = p_.dead_volume_m3 + area_a_ * std::max(len - len_min_, 0.0);
        const double vb = p_.dead_volume_m3 + area_b_ * std::max(len_max_ - len, 0.0);
        const double drop_a = ldot >= 0 ? ps - pa_ : pa_ - pr;
        const double drop_b = ldot >= 0 ? pb_ - pr : ps - pb_;
        const double demand = area_a_ * area_a_ / va + area_b_ * area_b_ / vb;
        const double supply = area_a_ * std::sqrt(std::max(drop_a, lam)) / va +
                              area_b_ * std::sqrt(std::max(drop_b, lam)) / vb;
        u_ff = ldot * demand / (k_orifice_ * supply);
      }
      u = kp_ * e + ki_ * integral_ + u_ff;
      // anti-windup: integrate only while the command is not saturated
      if (std::abs(u) < 1.0) integral_ += e * loop_dt;
      u = std::clamp(u, -1.0, 1.0);
    }
    for (int s = 0; s < substeps_per_loop_; ++s) {
      const double qs = q0 + qd * (t + 0.5 * h_);
      const double rs = Lever(qs);
      const double ldot = rs * qd;
      const double len = Length(qs);
      // spool (1), semi-implicit Euler, on its stops at ±1
      xd_ += h_ * (w * w * (u - x_) - 2 * z * w * xd_);
      x_ += h_ * xd_;
      if (std::abs(x_) >= 1.0) {
        x_ = std::clamp(x_, -1.0, 1.0);
        xd_ = 0.0;
      }
      const double xp = std::max(x_, 0.0), xn = std::max(-x_, 0.0);
      // orifices (2) and their slopes in the chamber's own pressure (≤ 0)
      const double qa = k_orifice_ * (xp * Root(ps - pa_, lam) - xn * Root(pa_ - pr, lam)) +
                        g_leak_ * (ps + pr - 2 * pa_);
      const double dqa =
          -k_orifice_ * (xp * RootSlope(ps - pa_, lam) + xn * RootSlope(pa_ - pr, lam)) - 2 * g_leak_;
      const double qb = k_orifice_ * (xn * Root(ps - pb_, lam) - xp * Root(pb_ - pr, lam)) +
                        g_leak_ * (ps + pr - 2 * pb_);
      const double dqb =
          -k_orifice_ * (xn * RootSlope(ps - pb_, lam) + xp * RootSlope(pb_ - pr, lam)) - 2 * g_leak_;
      // chambers (3), implicit in the orifice term
      const double va = p_.dead_volume_m3 + area_a_ * std::max(len - len_min_, 0.0);
      const double vb = p_.dead_volume_m3 + area_b_ * std::max(len_max_ - len, 0.0);
      const double ca = h_ * p_.bulk_modulus_Pa / va, cb = h_ * p_.bulk_modulus_Pa / vb;
      pa_ += ca * (qa - area_a_ * ldot) / (1.0 - ca * dqa);
      pb_ += cb * (qb + area_b_ * ldot) / (1.0 - cb * dqb);
      pa_ = std::clamp(pa_, 0.0, p_max);
      pb_ = std::clamp(pb_, 0.0, p_max);
      // rod force and joint torque (4)
      force_ = pa_ * area_a_ - pb_ * area_b_ - f_c_ * std::tanh(ldot / v_s_) - b_ * ldot;
      tau_Nm_ = force_ * rs;
      tau_sum += tau_Nm_;
      t += h_;
    }
  }
  return tau_sum / p_.substeps;
}

}  // namespace hyq::sim
