// The project's URDF carries the facts of the upstream HyQ description
// (../shared/models/hyq_description): masses, COMs, inertias, joint placements, axes and limits
// agree to 1e-9. Both files are read with urdfdom directly (not with our loader).
#include <cstdio>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <urdf_parser/urdf_parser.h>

#include "tests/support/paths.h"

namespace hyq {
namespace {

constexpr double kTol = 1e-9;

Eigen::Matrix3d Rot(const urdf::Rotation& r) {
  return Eigen::Quaterniond(r.w, r.x, r.y, r.z).toRotationMatrix();
}
Eigen::Vector3d Vec(const urdf::Vector3& v) { return {v.x, v.y, v.z}; }

class UrdfReference : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto shared = testing::SharedDir();
    if (shared.empty())
      GTEST_SKIP() << "../shared is absent beside the checkout: no upstream HyQ model to compare";
    const auto ref_path = shared / "models/hyq_description/robots/hyq_no_sensors.urdf";
    ref_ = urdf::parseURDFFile(ref_path.string());
    ours_ = urdf::parseURDFFile(testing::ProjectUrdf().string());
    ASSERT_TRUE(ref_) << ref_path;
    ASSERT_TRUE(ours_);
  }
  urdf::ModelInterfaceSharedPtr ref_, ours_;
};

TEST_F(UrdfReference, LinksHaveTheSameInertials) {
  int compared = 0;
  for (const char* leg : {"lf", "rf", "lh", "rh"})
    for (const char* part : {"hipassembly", "upperleg", "lowerleg"}) {
      const std::string name = std::string(leg) + "_" + part;
      SCOPED_TRACE(name);
      auto a = ours_->getLink(name);
      auto b = ref_->getLink(name);
      ASSERT_TRUE(a && b && a->inertial && b->inertial);
      EXPECT_NEAR(a->inertial->mass, b->inertial->mass, kTol);
      EXPECT_TRUE(Vec(a->inertial->origin.position).isApprox(Vec(b->inertial->origin.position), kTol) ||
                  (Vec(a->inertial->origin.position) - Vec(b->inertial->origin.position)).norm() < kTol);
      auto inertia = [](const urdf::Inertial& in) {
        Eigen::Matrix3d I;
        I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
        const Eigen::Matrix3d R = Rot(in.origin.rotation);
        return Eigen::Matrix3d(R * I * R.transpose());
      };
      EXPECT_LT((inertia(*a->inertial) - inertia(*b->inertial)).cwiseAbs().maxCoeff(), kTol);
      ++compared;
    }
  for (const char* name : {"trunk", "trunk_imu"}) {
    SCOPED_TRACE(name);
    auto a = ours_->getLink(name);
    auto b = ref_->getLink(name);
    ASSERT_TRUE(a && b && a->inertial && b->inertial);
    EXPECT_NEAR(a->inertial->mass, b->inertial->mass, kTol);
    EXPECT_LT((Vec(a->inertial->origin.position) - Vec(b->inertial->origin.position)).norm(), kTol);
    EXPECT_NEAR(a->inertial->ixx, b->inertial->ixx, kTol);
    EXPECT_NEAR(a->inertial->ixy, b->inertial->ixy, kTol);
    EXPECT_NEAR(a->inertial->ixz, b->inertial->ixz, kTol);
    EXPECT_NEAR(a->inertial->iyy, b->inertial->iyy, kTol);
    EXPECT_NEAR(a->inertial->iyz, b->inertial->iyz, kTol);
    EXPECT_NEAR(a->inertial->izz, b->inertial->izz, kTol);
    ++compared;
  }
  std::printf("compared the inertials of %d links\n", compared);
}

TEST_F(UrdfReference, JointsHaveTheSamePlacementAxisAndLimits) {
  int compared = 0;
  for (const char* leg : {"lf", "rf", "lh", "rh"})
    for (const char* part : {"haa", "hfe", "kfe", "foot"}) {
      const std::string name = std::string(leg) + "_" + part + "_joint";
      SCOPED_TRACE(name);
      auto a = ours_->getJoint(name);
      auto b = ref_->getJoint(name);
      ASSERT_TRUE(a && b);
      EXPECT_EQ(a->type, b->type);
      EXPECT_EQ(a->parent_link_name, b->parent_link_name);
      EXPECT_EQ(a->child_link_name, b->child_link_name);
      const auto& ta = a->parent_to_joint_origin_transform;
      const auto& tb = b->parent_to_joint_origin_transform;
      EXPECT_LT((Vec(ta.position) - Vec(tb.position)).norm(), kTol);
      // the upstream file writes π/2 as 1.57079632679 (5e-12 short): within tolerance
      EXPECT_LT((Rot(ta.rotation) - Rot(tb.rotation)).cwiseAbs().maxCoeff(), kTol);
      if (b->type == urdf::Joint::FIXED) {
        ++compared;
        continue;
      }
      EXPECT_LT((Vec(a->axis) - Vec(b->axis)).norm(), kTol);
      ASSERT_TRUE(a->limits && b->limits);
      EXPECT_NEAR(a->limits->lower, b->limits->lower, kTol);
      EXPECT_NEAR(a->limits->upper, b->limits->upper, kTol);
      EXPECT_NEAR(a->limits->effort, b->limits->effort, kTol);
      EXPECT_NEAR(a->limits->velocity, b->limits->velocity, kTol);
      ++compared;
    }
  auto a = ours_->getJoint("trunk_imu_joint");
  auto b = ref_->getJoint("trunk_imu_joint");
  ASSERT_TRUE(a && b);
  EXPECT_LT((Vec(a->parent_to_joint_origin_transform.position) -
             Vec(b->parent_to_joint_origin_transform.position)).norm(), kTol);
  EXPECT_LT((Rot(a->parent_to_joint_origin_transform.rotation) -
             Rot(b->parent_to_joint_origin_transform.rotation)).cwiseAbs().maxCoeff(), kTol);
  std::printf("compared %d joints\n", compared + 1);
}

TEST_F(UrdfReference, FeetHaveTheSameSphere) {
  for (const char* leg : {"lf", "rf", "lh", "rh"}) {
    const std::string name = std::string(leg) + "_foot";
    auto radius = [](const urdf::LinkConstSharedPtr& l) {
      for (const auto& c : l->collision_array)
        if (c->geometry && c->geometry->type == urdf::Geometry::SPHERE)
          return static_cast<const urdf::Sphere&>(*c->geometry).radius;
      return -1.0;
    };
    EXPECT_NEAR(radius(ours_->getLink(name)), radius(ref_->getLink(name)), kTol) << name;
    EXPECT_FALSE(ours_->getLink(name)->inertial) << name << ": no dummy inertia";
  }
}

}  // namespace
}  // namespace hyq
