// The plant a tool runs on, from its command line: --profile NAME, then each factor's flag on
// top of it whatever the order (hyq-sim and hyq-experiment; docs/simulation.md, "Plant profiles").
//
//   hyq::cli::PlantProfileFlags plant(/*sensors=*/true);
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
  /// `sensors`: whether the plant reports through the robot's sensors (hyq-sim's boards and IMU),
  /// and so --imu-bias, the noise flags and --joint-velocity are among the flags.
  explicit PlantProfileFlags(bool sensors) : sensors_(sensors) {}

  /// Reads the current argument when it is one of the flags: --profile ideal|realistic,
  /// --payload KG,X,Y,Z|off, --link-errors SEED|off, --hydraulics on|off, --joint-friction on|off
  /// (realistic's levels), --delay-cycles K, --load-cell-bias NM, --bias-seed N; with sensors
  /// also --imu-bias G,A, --encoder-noise RAD, --load-cell-noise NM, --imu-noise G[,A],
  /// --joint-velocity board|exact, --velocity-cutoff HZ. A bad value is a usage error naming the
  /// flag (or the part of it), what was expected and what was found. False for another argument.
  bool Read(CommandLine& cl);

  /// The named profile with every factor's flag applied.
  sim::PlantProfile Profile() const;

 private:
  bool sensors_;
  sim::PlantProfile named_ = sim::PlantProfile::Ideal();
  std::vector<std::function<void(sim::PlantProfile*)>> factors_;
};

}  // namespace hyq::cli
