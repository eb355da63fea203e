// One joint's feedback loop as the daemon and the simulated plant close it at the sample period
// T (1 ms), every element a discrete transfer function in z (transfer_function.h), and its
// stability margins. Step n takes the joint from state n to n + 1 under the torque τ[n]:
//
//   controller   u[n] = C(z) e[n − d],  e = −q_meas (the reference's own motion left out)
//                C(z) = kp + ki T z / (z − 1) + kd V(z)                                    (1)
//   velocity     V(z) = α (z − 1) / (T (z − (1 − α)))    the boards' encoder difference and
//                first-order low-pass, α = 1 − e^{−2π f_c T} (sim/board_velocity.h, eq. (3))
//   delay        d = 1 + d_p + K cycles: the bus's one (SYNC k's set-points, computed from the
//                answers to SYNC k − 1, drive step k; docs/simulation.md, "Modes"), the
//                plant's own transport delay d_p, and K more
//   actuator     τ[n] = A(z) u[n] − Z(z) q̇[n]: A the set-point → applied torque, Z the torque
//                the joint's own motion costs (the hydraulics' flow and friction; 0 for the lag);
//                the lag plant's A(z) = α_a z / (z − (1 − α_a)), α_a = 1 − e^{−T/τ_a}
//                (sim/plant_profile.cc, Actuation::Step: SimulatedRobot's eq. (1))
//   mechanics    q̇[n+1] = q̇[n] + T τ[n] / I,  q[n+1] = q[n] + T q̇[n+1]   (MuJoCo's
//                semi-implicit Euler: P_v = (T/I)/(z − 1), P_q = (T²/I) z/(z − 1)²), or the
//                continuous 1/(I s²) behind a zero-order hold: q[n+1] = q[n] + T q̇[n] +
//                T² τ[n] / (2I), P_q = (T²/I)(z + 1)/(2 (z − 1)²)
//   loop         L(z) = z^{−d} C(z) P_q A / (1 + (Z + b) P_v)                               (2)
// with b the plant's viscous joint friction.
//
// The closed loop's poles are the eigenvalues of its state-space matrix: each block realised
// on its own (a controllable canonical form of its few states, a shift register for the delay)
// and connected as above. Not the roots of num(L) + den(L): with the integrators' triple pole at
// z = 1 and the actuator's slow poles, that polynomial's expanded coefficients (binomial-sized
// for (z − 1)^n) put its roots near 1 off by ~10⁻⁴, enough to call a stable loop unstable.
// The margins come from L(e^{jωT}), 0 < ω < π/T, each block evaluated on its own:
//   gain crossover ω_c: |L| = 1;  phase margin φ = π + arg L(ω_c) (wrapped to (−π, π]);
//   delay margin τ_m = min over crossovers of (φ mod 2π) / ω_c: the extra delay, continuous,
//   that puts a closed-loop pole on the unit circle at ω_c (0 when the loop is unstable);
//   gain margin: the least 1 / |L| where arg L = −π (mod 2π) and |L| < 1.
#pragma once

#include <complex>
#include <vector>

#include <Eigen/Core>

#include "tools/loop_model/transfer_function.h"

namespace hyq::loop_model {

enum class Mechanics { kSemiImplicitEuler, kZeroOrderHold };

struct JointLoop {
  double period_s = 1e-3;
  double inertia_kgm2 = 1.0;
  double kp = 0.0;  // N·m/rad
  double kd = 0.0;  // N·m·s/rad
  double ki = 0.0;  // N·m/(rad·s)
  double velocity_alpha = 1.0;      // α of V(z); 1: the plain difference
  int delay_cycles = 1;             // 1 + d_p (the extra K is an argument)
  TransferFunction actuator;        // A(z)
  TransferFunction motion = TransferFunction::Gain(0.0);  // Z(z), N·m per rad/s
  double viscous_Nms = 0.0;         // b
  Mechanics mechanics = Mechanics::kSemiImplicitEuler;
};

/// C(z) of (1).
TransferFunction Controller(const JointLoop& loop);

/// L(e^{jθ}) of (2) with K extra cycles of delay.
std::complex<double> OpenLoopAt(const JointLoop& loop, int extra_cycles, double theta_rad);

/// The closed loop's state-space matrix with K extra cycles (its eigenvalues are the poles).
Eigen::MatrixXd ClosedLoopMatrix(const JointLoop& loop, int extra_cycles);
/// Its eigenvalues.
Eigen::VectorXcd ClosedLoopPoles(const JointLoop& loop, int extra_cycles);
/// Whether every closed-loop pole is strictly inside the unit circle (|z| < 1 − 10⁻⁹).
bool ClosedLoopStable(const JointLoop& loop, int extra_cycles);

struct Margins {
  bool stable = false;             // the closed loop, with K = 0 extra
  bool has_crossover = false;
  double crossover_hz = 0.0;       // the crossover that sets the delay margin
  double phase_margin_deg = 0.0;
  double delay_margin_s = 0.0;     // ∞ without a crossover; 0 when the loop is unstable
  double gain_margin = 0.0;        // ∞ without a phase crossover at |L| < 1
  double phase_crossover_hz = 0.0;
};

/// The margins of the loop with no extra delay, searched from f_lo_hz to the Nyquist frequency.
Margins ComputeMargins(const JointLoop& loop, double f_lo_hz = 0.05);

struct ClosedLoopRoot {
  std::complex<double> z;
  double magnitude = 0.0;
  double frequency_hz = 0.0;  // |arg z| / (2π T)
};

/// The closed-loop pole of largest magnitude with K extra cycles; with `oscillatory`, of those
/// off the real axis (the least damped oscillation: the slow real poles of the integrators and
/// the actuator's slowest mode say little about the ringing).
ClosedLoopRoot DominantRoot(const JointLoop& loop, int extra_cycles, bool oscillatory = false);

/// The largest K in [0, k_max] such that the loop is stable with 0, 1, ..., K extra cycles;
/// −1 when unstable with none.
int MaxStableExtraCycles(const JointLoop& loop, int k_max);

}  // namespace hyq::loop_model
