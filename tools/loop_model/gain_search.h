// The gains the loop model allows with a required delay margin of K extra cycles, per joint type
// (haa, hfe, kfe):
//  1. the stance gains: the largest factor c on the configured (kp, kd) of that type — their
//     ratio kept, so the loop's shape is the configured one — such that every leg's loop of that
//     type in stance and in stand, on every modelled plant, stays stable (all closed-loop roots
//     inside the unit circle) with 0, 1, ..., K extra cycles of delay, at the standing inertia
//     and at both ends of its range over the trot; at most the configuration's bounds
//     (servo::kMaxKpTau, kMaxKdTau);
//  2. the swing scale: with those stance gains, the largest s in [0.05, 1] that keeps the same
//     in swing; when none does, the s whose worst plant keeps the most extra cycles, and the
//     swing PD (kp, kd on a log grid, any ratio) that keeps the most.
// Both scan a grid (the allowed set need not be an interval: the lag plant loses margin as the
// gains rise, the hydraulics' negative motion impedance needs damping enough to be overcome)
// and refine the largest allowed point's edge by bisection.
#pragma once

#include <array>
#include <string>

#include "tools/loop_model/loop_model.h"

namespace hyq::loop_model {

struct TypeGains {
  double kp = 0.0, kd = 0.0;     // the stance gains found (the type's largest over the legs)
  double stance_factor = 0.0;    // c (0: no factor keeps the margin)
  double stance_min_factor = 0.0;  // the smallest allowed c on the grid
  std::string stance_limit;      // what stops c from rising: a leg, phase and plant, or the bound
  bool swing_found = false;      // some s keeps the margin in swing
  double swing_scale = 0.0;      // the largest such s, or the best compromise
  double swing_min_scale = 0.0;  // the smallest allowed s on the grid (swing_found)
  std::string swing_limit;
  int swing_worst_cycles = -1;   // at swing_scale: the fewest exact extra cycles over the plants
  // without a scale: the swing PD of any kp:kd keeping the most extra cycles on its worst plant
  double swing_best_kp = 0.0, swing_best_kd = 0.0;
  int swing_best_cycles = -1;
};

struct SearchResult {
  std::array<TypeGains, dynamics::kJointsPerLeg> types;
};

/// The fewest exact extra cycles (up to k_max) of joint's loop in `phase` on `plant` with gains
/// g, over the phase's nominal inertia and both ends of its range.
int WorstExtraCycles(const LoopModel& m, const JointGains& g, int joint, Phase phase,
                     PlantKind plant, int k_max);

/// The search above on the plants `m` was built with.
SearchResult SearchGains(const LoopModel& m, int required_extra_cycles);

}  // namespace hyq::loop_model
