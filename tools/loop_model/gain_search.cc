#include "tools/loop_model/gain_search.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace hyq::loop_model {
namespace {

using dynamics::kJointsPerLeg;
using dynamics::kNumLegs;

constexpr int kGrid = 100;        // scan points over a factor's range
constexpr int kBisections = 20;   // refining the largest allowed point's edge

struct Check {
  int worst = 0;        // the fewest extra cycles over the legs, phases and plants checked
  std::string where;    // the leg, phase and plant that has them
};

Check Worst(const LoopModel& m, const JointGains& g, int t, std::initializer_list<Phase> phases,
            const std::set<PlantKind>& plants, int k_max) {
  Check c{k_max + 1, ""};
  for (PlantKind plant : plants)
    for (Phase phase : phases)
      for (int leg = 0; leg < kNumLegs; ++leg) {
        const int k = WorstExtraCycles(m, g, kJointsPerLeg * leg + t, phase, plant, k_max);
        if (k < c.worst) {
          c.worst = k;
          c.where = std::string(dynamics::kLegNames[static_cast<std::size_t>(leg)]) + " " +
                    ToString(phase) + " on the " + ToString(plant) + " plant";
        }
      }
  return c;
}

JointGains Scaled(const JointGains& g, int t, double c) {
  JointGains out = g;
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const int j = kJointsPerLeg * leg + t;
    out.kp(j) *= c;
    out.kd(j) *= c;
  }
  return out;
}

struct Scan {
  bool found = false;
  double largest = 0.0, smallest = 0.0;  // allowed
  double best = 0.0;                     // the most cycles when none is allowed
  int best_cycles = -1;
  std::string limit;                     // what fails just above `largest`
};

// x on a grid over [lo, hi]: allowed when check(x).worst >= k; the largest allowed refined
// towards the next grid point by bisection
template <class F>
Scan ScanFactor(double lo, double hi, int k, const F& check) {
  Scan s;
  double next_failing = -1.0;
  for (int i = kGrid; i >= 0; --i) {
    const double x = lo + (hi - lo) * i / kGrid;
    const Check c = check(x);
    if (c.worst > s.best_cycles) {
      s.best_cycles = c.worst;
      s.best = x;
    }
    if (c.worst >= k) {
      if (!s.found) {
        s.found = true;
        s.largest = x;
      }
      s.smallest = x;
    } else if (!s.found) {
      next_failing = x;
      s.limit = c.where;
    }
  }
  if (s.found && next_failing > 0.0) {
    double a = s.largest, b = next_failing;
    for (int i = 0; i < kBisections; ++i) {
      const double mid = 0.5 * (a + b);
      const Check c = check(mid);
      if (c.worst >= k) {
        a = mid;
      } else {
        b = mid;
        s.limit = c.where;
      }
    }
    s.largest = a;
  }
  return s;
}

}  // namespace

int WorstExtraCycles(const LoopModel& m, const JointGains& g, int joint, Phase phase,
                     PlantKind plant, int k_max) {
  const PhaseInertia& in = m.inertia[static_cast<std::size_t>(phase)];
  const ActuatorModel& a = m.actuators[static_cast<std::size_t>(plant)][static_cast<std::size_t>(phase)]
                                      [static_cast<std::size_t>(joint)];
  int worst = k_max;
  for (double I : {in.nominal(joint), in.min(joint), in.max(joint)})
    worst = std::min(worst, MaxStableExtraCycles(MakeJointLoop(m.settings, g, a, joint, phase, I), worst));
  return worst;
}

SearchResult SearchGains(const LoopModel& m, int k) {
  std::set<PlantKind> plants;
  for (const LoopRow& r : m.rows) plants.insert(r.plant);
  SearchResult out;
  for (int t = 0; t < kJointsPerLeg; ++t) {
    TypeGains& tg = out.types[static_cast<std::size_t>(t)];
    // the factor's bound: the configuration's largest gains on this type's joints
    double kp_max = 0.0, kd_max = 0.0;
    for (int leg = 0; leg < kNumLegs; ++leg) {
      kp_max = std::max(kp_max, m.gains.kp(kJointsPerLeg * leg + t));
      kd_max = std::max(kd_max, m.gains.kd(kJointsPerLeg * leg + t));
    }
    double cap = 20.0;
    if (kp_max > 0) cap = std::min(cap, servo::kMaxKpTau / kp_max);
    if (kd_max > 0) cap = std::min(cap, servo::kMaxKdTau / kd_max);
    // 1. the stance factor
    const Scan st = ScanFactor(0.0, cap, k, [&](double c) {
      return Worst(m, Scaled(m.gains, t, c), t, {Phase::kTrotStance, Phase::kStand}, plants, k);
    });
    tg.stance_factor = st.found ? st.largest : 0.0;
    tg.stance_min_factor = st.found ? st.smallest : 0.0;
    tg.stance_limit = !st.found ? "no factor keeps the margin (best " + std::to_string(st.best_cycles) + ")"
                      : st.limit.empty() ? "the configuration's gain bound"
                                         : st.limit;
    tg.kp = tg.stance_factor * kp_max;
    tg.kd = tg.stance_factor * kd_max;
    // 2. the swing scale with those stance gains
    const JointGains stance = Scaled(m.gains, t, tg.stance_factor);
    const Scan sw = ScanFactor(0.05, 1.0, k, [&](double s) {
      JointGains g = stance;
      g.swing_scale = s;
      return Worst(m, g, t, {Phase::kSwing}, plants, k);
    });
    tg.swing_found = sw.found;
    tg.swing_scale = sw.found ? sw.largest : sw.best;
    tg.swing_min_scale = sw.found ? sw.smallest : 0.0;
    tg.swing_limit = sw.limit.empty() ? "the scale's bound 1" : sw.limit;
    JointGains g = stance;
    g.swing_scale = tg.swing_scale;
    tg.swing_worst_cycles = Worst(m, g, t, {Phase::kSwing}, plants, k + 10).worst;
    if (sw.found) continue;
    // 3. no scale: the swing PD of any ratio, kp 10..3000 N·m/rad and kd 0.5..100 N·m·s/rad
    // on log grids, that keeps the most on its worst plant (the lowest gains among equals)
    constexpr int kLog = 24;
    for (int i = 0; i <= kLog; ++i)
      for (int jd = 0; jd <= kLog; ++jd) {
        const double kp = 10.0 * std::pow(300.0, static_cast<double>(i) / kLog);
        const double kd = 0.5 * std::pow(200.0, static_cast<double>(jd) / kLog);
        JointGains gs = stance;
        gs.swing_scale = 1.0;
        for (int leg = 0; leg < kNumLegs; ++leg) {
          gs.kp(kJointsPerLeg * leg + t) = kp;
          gs.kd(kJointsPerLeg * leg + t) = kd;
        }
        const int c = Worst(m, gs, t, {Phase::kSwing}, plants, k).worst;
        if (c > tg.swing_best_cycles) {
          tg.swing_best_cycles = c;
          tg.swing_best_kp = kp;
          tg.swing_best_kd = kd;
        }
      }
  }
  return out;
}

}  // namespace hyq::loop_model
