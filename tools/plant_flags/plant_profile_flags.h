// The plant a tool runs on, from its command line: --profile NAME, then each factor's flag on
// top of it whatever the order (hyq-sim and hyq-experiment; docs/simulation.md, "Plant profiles").
//
//   hyq::cli::PlantProfileFlags plant(/*imu=*/true);
//   while (cl.Next()) {
//     if (plant.Read(cl)) continue;
//     ...
//   }
//   config.profile = plant.Profile();
#pragma once

#include <functional>
#include <vector>

#include "sim/plant_profile.h"
#include "tools/cli/command_line.h"

namespace hyq::cli {

class PlantProfileFlags {
 public:
  /// `imu`: whether the plant has an IMU, and so --imu-bias is one of the flags.
  explicit PlantProfileFlags(bool imu) : imu_(imu) {}

  /// Reads the current argument when it is one of the flags: --profile ideal|realistic,
  /// --payload KG,X,Y,Z|off, --link-errors SEED|off, --hydraulics on|off, --joint-friction on|off
  /// (realistic's levels), --delay-cycles K, --load-cell-bias NM, --imu-bias G,A, --bias-seed N.
  /// A bad value is a usage error naming the flag (or the part of it), what was expected and what
  /// was found. False for another argument.
  bool Read(CommandLine& cl);

  /// The named profile with every factor's flag applied.
  sim::PlantProfile Profile() const;

 private:
  bool imu_;
  sim::PlantProfile named_ = sim::PlantProfile::Ideal();
  std::vector<std::function<void(sim::PlantProfile*)>> factors_;
};

}  // namespace hyq::cli
