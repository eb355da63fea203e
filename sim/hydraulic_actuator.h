// One of HyQ's torque-controlled hydraulic joints: a servo valve, the
// actuator's two chambers, seal friction, and the board's low-level torque loop, integrated with
// sub-steps inside the plant's 1 ms step. HFE/KFE: an asymmetric cylinder acting through the
// HAL's lever arm r(q) (hal/calibration.h, eq. (2)-(3)); HAA: a rotary actuator (r = 1).
// docs/simulation.md, "Hydraulic actuators", gives every parameter with its source.
//
// Per sub-step h (x the valve spool, normalised to ±1; chambers a (piston side) and b (rod side)):
//   spool, 2nd order:   ẍ = ω_v² (u − x) − 2 ζ_v ω_v ẋ,  |x| ≤ 1 (the spool's stops)          (1)
//   orifices, turbulent: Q_a = K (x⁺ √(p_s − p_a) − x⁻ √(p_a − p_r)) + g (p_s + p_r − 2 p_a),
//                        Q_b = K (x⁻ √(p_s − p_b) − x⁺ √(p_b − p_r)) + g (p_s + p_r − 2 p_b),
//                        K = Q_n / √(Δp_n / 2),  g = π r_c² w / (32 μ)                        (2)
//     (√ made linear below Δp_lam so that its slope stays finite; |x| ≤ 1 is the flow saturation;
//     g the laminar leakage of each land of a critical-centre spool through its radial clearance
//     r_c, port width w, oil viscosity μ: Merritt, Hydraulic Control Systems (1967), §2.6, the
//     leakage coefficient at null K_c0)
//   chambers, oil compressibility (β the effective bulk modulus):
//     ṗ_a = β / V_a(L) (Q_a − A_a L̇),   ṗ_b = β / V_b(L) (Q_b + A_b L̇)                       (3)
//     V_a = V_0 + A_a (L − L_min),  V_b = V_0 + A_b (L_max − L);  L̇ = r(q) q̇
//   rod force (what the load cell measures) and joint torque:
//     F = p_a A_a − p_b A_b − F_c tanh(L̇ / v_s) − b L̇,   τ = F r(q)                         (4)
// (3) is integrated implicitly in the orifice term (its slope ∂Q/∂p ≤ 0), so that an almost empty
// chamber does not need a tiny step. The board's torque loop (Boaventura et al. 2012: PID on the
// load-cell force plus a velocity compensation that opens the valve for the flow the motion
// needs) runs at loop_rate_hz with a zero-order hold on u:
//   u = k_p e + k_i ∫e + u_v,   e = τ_ref / r(q) − F                                         (5)
// with u_v the opening whose flows, by (2)-(3), leave the rod force's rate A_a ṗ_a − A_b ṗ_b
// unchanged by the motion L̇ (the compensation cancels the cylinder's natural velocity feedback,
// no more: sized for the piston side alone, the same opening over-fed the rod side, and the
// joint pushed along its own motion, a negative damping of ≈ −10 N·m·s/rad at 10 Hz that
// hyq-loop-model measured):
//   u_v = L̇ (A_a²/V_a + A_b²/V_b) / (K (A_a √Δp_a / V_a + A_b √Δp_b / V_b))                  (6)
// (Δp_a, Δp_b the orifice drops the motion's flows pass: p_s − p_a and p_b − p_r extending,
// p_a − p_r and p_s − p_b retracting)
// The joint moves during the plant step as q + q̇ t (the plant's state at the step's start).
// A board whose outputs are off (disabled, tripped, booting) drives no valve current: the spool's
// springs centre it (u = 0 in (1)), the ports close and the joint is hydraulically locked, held by
// the oil in its chambers and creeping only by the lands' leakage g. Without the torque loop, the
// creep under a load force F is, from (2)-(4) at rest, L̇ ≈ −2 g (F − F_0) / (A_a² + A_b²), with
// F_0 = (p_s + p_r)(A_a − A_b)/2 the rod's own push at null: LockDamping() is that slope at the
// joint, r(q)² (A_a² + A_b²) / (2 g), which the profiles without hydraulics apply to a joint whose
// board is off.
//
// Step() allocates nothing and never throws; the constructor checks the parameters (throws).
#pragma once

#include <stdexcept>
#include <string>

#include "hal/calibration.h"

namespace hyq::sim {

/// The parameters of one actuator type; the defaults are HyQ's (docs/simulation.md).
struct HydraulicParams {
  double supply_pressure_Pa = 20e6;        // p_s
  double return_pressure_Pa = 0.0;         // p_r (gauge)
  double bulk_modulus_Pa = 1.0e9;          // β, effective (oil, hoses, entrained air)
  double valve_bandwidth_hz = 250.0;       // ω_v / 2π (Moog E024)
  double valve_damping = 0.7;              // ζ_v
  double valve_rated_flow_m3_s = 2.5e-3 / 60.0;  // Q_n at Δp_n (2.5 l/min)
  double valve_rated_drop_Pa = 7e6;        // Δp_n, over both lands
  double laminar_drop_Pa = 0.2e6;          // Δp_lam: below it the orifice flow is linear in Δp
  // the spool lands' leakage g of (2): radial clearance (a matched spool and bushing), port width
  // (the rated flow through ≈ 0.2 mm of opening), the oil's viscosity (ISO VG 32 at 40 °C)
  double valve_radial_clearance_m = 1e-6;
  double valve_port_width_m = 4e-3;
  double oil_viscosity_Pa_s = 0.028;
  double dead_volume_m3 = 2e-6;            // V_0 per chamber: valve ports, manifold
  // cylinders (HFE, KFE)
  double piston_diameter_m = 0.016;
  double rod_diameter_m = 0.010;
  double stroke_margin_m = 0.005;          // chamber length left at each end of the joint range
  double seal_coulomb_N = 20.0;            // F_c
  double seal_viscous_N_s_m = 100.0;       // b
  double seal_band_m_s = 0.005;            // v_s
  // rotary (HAA): displacement per radian, friction at the joint
  double rotary_displacement_m3_rad = 10e-6;
  double rotary_margin_rad = 0.1;
  double rotary_seal_coulomb_Nm = 1.0;
  double rotary_seal_viscous_Nm_s = 0.5;
  double rotary_seal_band_rad_s = 0.05;
  // the board's torque loop (5); gains in valve command per N (cylinder) or per N·m (rotary)
  double loop_rate_hz = 1000.0;
  double cylinder_kp_per_N = 1.1e-4;
  double cylinder_ki_per_N_s = 0.0;
  double rotary_kp_per_Nm = 2.2e-3;
  double rotary_ki_per_Nm_s = 0.0;
  bool velocity_compensation = true;
  int substeps = 20;                       // per plant step (50 µs at 1 kHz)
};

class HydraulicActuator {
 public:
  /// `cal` gives the kind (cylinder through its lever arm, or rotary) and the geometry;
  /// [q_min, q_max] the joint range (the chambers' volumes). Throws std::invalid_argument naming
  /// `joint` when a parameter is unusable.
  HydraulicActuator(const HydraulicParams& p, const hal::JointCalibration& cal, double q_min_rad,
                    double q_max_rad, double plant_step_s, const std::string& joint);

  /// At rest at q with the joint torque tau (spool centred, the torque loop's integral zero).
  void Reset(double q_rad, double tau_Nm) noexcept;
  /// One plant step with the set-point tau_ref (the joint at q, moving at qd). Returns the mean
  /// joint torque over the step (what the plant applies); torque_Nm() is the torque at its end.
  /// outputs_on false: the board drives no valve current (the spool centres, the joint locks).
  double Step(double tau_ref_Nm, double q_rad, double qd_rad_s, bool outputs_on = true) noexcept;
  /// The locked joint's resistance to motion at q (valve at null, see above), N·m·s/rad.
  double LockDamping(double q_rad) const noexcept;
  /// The most a locked joint resists with at q: a chamber at the relief valve's pressure
  /// (kReliefRatio p_s), the other empty, N·m.
  double LockTorqueLimitNm(double q_rad) const noexcept;
  static constexpr double kReliefRatio = 1.5;
  /// g of (2), m³/(s·Pa).
  double land_leakage() const noexcept { return g_leak_; }

  double torque_Nm() const noexcept { return tau_Nm_; }
  double pressure_a_Pa() const noexcept { return pa_; }
  double pressure_b_Pa() const noexcept { return pb_; }
  double spool() const noexcept { return x_; }
  /// Lever arm r(q) (1 for rotary), m.
  double Lever(double q_rad) const noexcept;
  /// The largest torque the actuator can hold at q (one chamber at p_s, the other at p_r), for
  /// a positive and a negative set-point.
  double MaxTorqueNm(double q_rad, bool positive) const noexcept;

 private:
  double Length(double q_rad) const noexcept;

  HydraulicParams p_;
  hal::JointCalibration cal_;
  bool rotary_;
  double area_a_, area_b_;          // m² (rotary: displacement, m³/rad)
  double len_min_, len_max_;        // the chambers' ends (L or q)
  double k_orifice_;                // K of (2)
  double g_leak_;                   // g of (2)
  double kp_, ki_, f_c_, b_, v_s_;  // per kind
  double h_;                        // sub-step, s
  int substeps_per_loop_, loops_;
  // state
  double x_ = 0, xd_ = 0, pa_ = 0, pb_ = 0, integral_ = 0, tau_Nm_ = 0, force_ = 0;
};

}  // namespace hyq::sim
