#include "servo/estimation/friction_estimator.h"

#include <algorithm>
#include <cmath>

namespace hyq::servo {

FrictionEstimator::FrictionEstimator(const FrictionEstimatorConfig& config) : config_(config) {
  Reset();
}

void FrictionEstimator::Reset() noexcept {
  for (FootFriction& f : feet_) {
    f = FootFriction{};
    f.mu = config_.prior_mu;
    f.mu_control = std::max(config_.min_mu, (1.0 - config_.margin) * config_.prior_mu);
  }
  slip_run_.fill(0);
  loaded_s_.fill(0.0);
  touchdown_W_.fill(Eigen::Vector3d::Zero());
  places_.fill(Place{});
  next_place_ = 0;
}

// a place within half the radius of one remembered is the same place: the newer estimate
// replaces the older (a stale one nearby must not be recalled instead); else the oldest goes
void FrictionEstimator::Remember(const Eigen::Vector3d& p_W, const FootFriction& foot) noexcept {
  const double same2 = 0.25 * config_.memory_radius_m * config_.memory_radius_m;
  for (Place& p : places_) {
    if (p.used && (p.x - p_W.x()) * (p.x - p_W.x()) + (p.y - p_W.y()) * (p.y - p_W.y()) < same2) {
      p = {p_W.x(), p_W.y(), foot.mu, foot.confidence, true};
      return;
    }
  }
  places_[static_cast<std::size_t>(next_place_)] = {p_W.x(), p_W.y(), foot.mu, foot.confidence, true};
  next_place_ = (next_place_ + 1) % kMemory;
}

// the nearest remembered place within the radius (the newest of equals)
const FrictionEstimator::Place* FrictionEstimator::Recall(const Eigen::Vector3d& p_W) const noexcept {
  const Place* best = nullptr;
  double best_d2 = config_.memory_radius_m * config_.memory_radius_m;
  for (int k = 1; k <= kMemory; ++k) {
    const Place& p = places_[static_cast<std::size_t>((next_place_ - k + kMemory) % kMemory)];
    if (!p.used) continue;
    const double d2 = (p.x - p_W.x()) * (p.x - p_W.x()) + (p.y - p_W.y()) * (p.y - p_W.y());
    if (d2 < best_d2) {
      best = &p;
      best_d2 = d2;
    }
  }
  return best;
}

void FrictionEstimator::Update(const std::array<FootFrictionInput, kNumFeet>& in,
                               const std::array<bool, kNumFeet>& evidence_ok,
                               const std::array<double, kNumFeet>& upper_mu, double dt) noexcept {
  const FrictionEstimatorConfig& c = config_;
  for (std::size_t i = 0; i < kNumFeet; ++i) {
    FootFriction& f = feet_[i];
    const FootFrictionInput& x = in[i];
    const double upper = std::isfinite(upper_mu[i]) ? std::max(c.min_mu, upper_mu[i]) : c.prior_mu;
    const double prior = std::min(c.prior_mu, upper);
    // ρ = |f_t| / f_n and the contact point's tangential speed, normal +z
    const double fn = x.force_W.z();
    const bool finite = x.force_W.allFinite() && x.velocity_W.allFinite() && x.position_W.allFinite();
    const bool loaded = finite && x.stance && fn > c.min_normal_N;
    f.force_W = finite ? x.force_W : Eigen::Vector3d::Zero();
    f.ratio = loaded ? x.force_W.head<2>().norm() / fn : 0.0;
    f.slip_speed_m_s = finite && x.stance ? x.velocity_W.head<2>().norm() : 0.0;
    f.evidence_held = false;

    if (!loaded) {
      // lift-off: the estimate stays at the place the foot landed
      if (f.loaded) Remember(touchdown_W_[i], f);
      f.loaded = false;
      f.slipping = false;
      slip_run_[i] = 0;
    } else {
      if (!f.loaded) {
        // footfall: from the estimate remembered here, else from the prior
        const Place* p = Recall(x.position_W);
        f.mu = p != nullptr ? p->mu : prior;
        f.confidence = p != nullptr ? p->confidence : 0.0;
        f.lower_bound = 0.0;
        f.slipping = false;
        slip_run_[i] = 0;
        loaded_s_[i] = 0.0;
        touchdown_W_[i] = x.position_W;
        ++f.footfalls;
      }
      f.loaded = true;
      loaded_s_[i] += dt;
      // Coulomb: the friction on a sliding contact opposes its velocity
      const Eigen::Vector2d f_t = x.force_W.head<2>(), v_t = x.velocity_W.head<2>();
      const bool opposed = -f_t.dot(v_t) >= c.slip_alignment * f_t.norm() * v_t.norm();
      slip_run_[i] = f.slip_speed_m_s > c.slip_speed_m_s && opposed ? slip_run_[i] + 1 : 0;
      if (loaded_s_[i] < c.touchdown_blank_s) {
        // the impact: neither a slip nor a bound
        slip_run_[i] = 0;
        f.slipping = false;
      } else if (!evidence_ok[i]) {
        // v_t against an untrusted base velocity: neither a slip nor a bound. The run restarts
        // rather than pausing: slip_cycles asks for that many measured cycles in a row, and a
        // false slip (μ̂ dropped to ρ at once) costs more than a real one found slip_cycles after
        // the evidence returns
        slip_run_[i] = 0;
        f.slipping = false;
        f.evidence_held = true;
        ++f.held_cycles;
      } else if (slip_run_[i] >= c.slip_cycles) {
        // sliding: the contact is on its cone, ρ = μ
        if (!f.slipping) {
          f.mu = f.ratio;
          ++f.slips;
        } else {
          f.mu += c.slip_filter * (f.ratio - f.mu);
        }
        f.slipping = true;
        f.confidence = 1.0;
        f.lower_bound = std::min(f.lower_bound, f.mu);
      } else if (f.slip_speed_m_s < c.stick_speed_m_s) {
        // sticking: inside the cone, μ ≥ ρ; with no slip, probe upwards towards the prior
        f.slipping = false;
        f.lower_bound = std::max(f.lower_bound, f.ratio);
        const double before = f.mu;
        f.mu = std::max(f.mu, f.lower_bound);
        if (f.mu < prior) f.mu = std::min(prior, f.mu + c.rise_per_s * dt);
        if (f.mu > before && f.mu > f.lower_bound)
          f.confidence *= std::exp(-dt / c.confidence_time_s);
      } else {
        // between the two speeds: neither proves anything, the estimate holds
        f.slipping = false;
      }
    }
    f.mu = std::clamp(f.mu, c.min_mu, std::max(c.min_mu, upper));
    f.mu_control = std::clamp((1.0 - c.margin) * f.mu, c.min_mu, upper);
  }
}

Eigen::Vector3d FootForceFromJointTorques(const dynamics::CycleDynamics& dyn, int leg,
                                          const Eigen::Vector3d& tau_leg_Nm) noexcept {
  const int col = 6 + 3 * leg;
  const Eigen::Matrix3d J = dyn.feet.J_WF[static_cast<std::size_t>(leg)].middleCols<3>(col);
  const Eigen::Vector3d rhs = dyn.bias.segment<3>(col) - tau_leg_Nm;
  const Eigen::PartialPivLU<Eigen::Matrix3d> lu(J.transpose());
  if (!(std::abs(lu.determinant()) > 1e-9)) return Eigen::Vector3d::Zero();
  return lu.solve(rhs);
}

FootFrictionInput MeasureFoot(const dynamics::Model& model, const dynamics::CycleDynamics& dyn,
                              const dynamics::VectorV& v, int leg, bool stance,
                              const Eigen::Vector3d& tau_leg_Nm) noexcept {
  const auto f = static_cast<std::size_t>(leg);
  FootFrictionInput in;
  in.stance = stance;
  in.force_W = FootForceFromJointTorques(dyn, leg, tau_leg_Nm);
  const Eigen::Vector3d w_W = dyn.feet.Jw_WF[f] * v;
  in.velocity_W = dyn.feet.v_WF_W[f] + w_W.cross(-model.feet[f].radius_m * Eigen::Vector3d::UnitZ());
  in.position_W = dyn.feet.p_WF_W[f];
  return in;
}

}  // namespace hyq::servo
