// Reads the HyQ model from a URDF file (urdfdom) at configuration time.
#pragma once

#include <string>

#include "dynamics/model.h"

namespace hyq::dynamics {

/// Loads and checks a HyQ URDF: a floating trunk, the 12 revolute joints
/// {lf,rf,lh,rh}_{haa,hfe,kfe}_joint in chains trunk → hipassembly → upperleg → lowerleg, a foot
/// link {leg}_foot fixed to each lower leg with a sphere collision (its radius is the foot
/// radius), positive masses and positive definite inertias, finite limits, and a
/// <hyq_posture name="standing" base_height=".."> element. Links attached by fixed joints are
/// lumped into their moving parent. An optional trunk_imu link gives the IMU frame.
/// @throws ModelError naming the file, the element, what was expected and what was found.
Model LoadModelFromUrdf(const std::string& path);

/// The same for URDF text already in memory; `source` names it in error messages.
Model LoadModelFromUrdfString(const std::string& xml, const std::string& source);

}  // namespace hyq::dynamics
