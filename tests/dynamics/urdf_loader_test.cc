// Bad model files get a clear error naming the file, the element, what was expected and found.
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dynamics/urdf_loader.h"
#include "tests/support/paths.h"

namespace hyq::dynamics {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::string ProjectUrdfText() {
  std::ifstream f(testing::ProjectUrdf());
  std::stringstream buf;
  buf << f.rdbuf();
  return buf.str();
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

std::string LoadError(const std::string& xml) {
  try {
    LoadModelFromUrdfString(xml, "bad.urdf");
  } catch (const ModelError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a ModelError";
  return "";
}

TEST(UrdfLoader, LoadsTheProjectModel) {
  const Model m = LoadModelFromUrdf(testing::ProjectUrdf().string());
  EXPECT_EQ(m.bodies[0].name, "trunk");
  EXPECT_EQ(m.bodies[1].name, "lf_hipassembly");
  EXPECT_EQ(m.bodies[12].name, "rh_lowerleg");
  EXPECT_EQ(m.bodies[3].parent, 2);
  EXPECT_EQ(m.feet[3].body, 12);
  EXPECT_DOUBLE_EQ(m.standing_base_height_m, 0.5993);
  EXPECT_DOUBLE_EQ(m.q_standing(JointIndex(2, 1)), -0.75);
}

TEST(UrdfLoader, MissingFile) {
  try {
    LoadModelFromUrdf("/nonexistent/hyq.urdf");
    FAIL();
  } catch (const ModelError& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("/nonexistent/hyq.urdf"), HasSubstr("cannot open")));
  }
}

TEST(UrdfLoader, MalformedXmlNamesTheLine) {
  const std::string xml = Replace(ProjectUrdfText(), "</robot>", "</robt>");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("bad.urdf"), HasSubstr("not well-formed XML"),
                                    HasSubstr("line")));
}

TEST(UrdfLoader, WrongJointCount) {
  // make one knee a fixed joint: 11 actuated joints
  const std::string xml = Replace(ProjectUrdfText(), "<joint name=\"rh_kfe_joint\" type=\"revolute\">",
                                  "<joint name=\"rh_kfe_joint\" type=\"fixed\">");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("bad.urdf"), HasSubstr("expected 12 actuated joints"),
                                    HasSubstr("found 11")));
}

TEST(UrdfLoader, WrongJointName) {
  std::string xml = std::regex_replace(ProjectUrdfText(), std::regex("lh_hfe_joint"), "lh_hip_joint");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("missing: lh_hfe_joint"), HasSubstr("lh_hip_joint")));
}

TEST(UrdfLoader, NonPositiveMass) {
  const std::string xml = Replace(ProjectUrdfText(), "<mass value=\"0.881\"/>", "<mass value=\"0\"/>");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("lf_lowerleg"), HasSubstr("positive mass"),
                                    HasSubstr("found 0")));
}

TEST(UrdfLoader, InertiaNotPositiveDefinite) {
  const std::string xml = Replace(ProjectUrdfText(), "ixx=\"0.00368\"", "ixx=\"-0.1\"");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("lf_upperleg"), HasSubstr("positive definite"),
                                    HasSubstr("eigenvalues")));
}

TEST(UrdfLoader, MissingFootFrame) {
  std::string xml = std::regex_replace(ProjectUrdfText(), std::regex("\"rf_foot\""), "\"rf_toe\"");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("expected a foot link 'rf_foot'"),
                                    HasSubstr("rf_lowerleg"), HasSubstr("found none")));
}

TEST(UrdfLoader, FootWithoutSphere) {
  const std::string xml =
      Replace(ProjectUrdfText(),
              "<link name=\"lh_foot\">\n    <collision>\n      <geometry><sphere radius=\"0.02175\"/>",
              "<link name=\"lh_foot\">\n    <collision>\n      <geometry><box size=\"0.1 0.1 0.1\"/>");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("lh_foot"), HasSubstr("sphere")));
}

TEST(UrdfLoader, MissingPosture) {
  const std::string xml = Replace(ProjectUrdfText(), "<hyq_posture name=\"standing\"",
                                  "<hyq_posture name=\"sitting\"");
  EXPECT_THAT(LoadError(xml), HasSubstr("expected a <hyq_posture name=\"standing\""));
}

// a NaN or out-of-range standing posture is refused at load: the servo would drive the robot
// towards it after enable
TEST(UrdfLoader, PostureNaNOrOutsideTheLimits) {
  std::string xml = Replace(ProjectUrdfText(), "<joint name=\"lf_kfe_joint\" position=\"-1.5\"/>",
                            "<joint name=\"lf_kfe_joint\" position=\"nan\"/>");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("lf_kfe_joint"), HasSubstr("within the joint's limits"),
                                    HasSubstr("found nan")));
  xml = Replace(ProjectUrdfText(), "<joint name=\"rh_hfe_joint\" position=\"-0.75\"/>",
                "<joint name=\"rh_hfe_joint\" position=\"7\"/>");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("rh_hfe_joint"), HasSubstr("found 7")));
  xml = Replace(ProjectUrdfText(), "base_height=\"0.5993\"", "base_height=\"inf\"");
  EXPECT_THAT(LoadError(xml), HasSubstr("positive, finite base_height"));
}

TEST(UrdfLoader, WeldedBase) {
  const std::string xml = Replace(ProjectUrdfText(), "type=\"floating\"", "type=\"fixed\"");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("root link 'world'"), HasSubstr("floating joint")));
}

TEST(UrdfLoader, BadLimits) {
  const std::string xml = Replace(ProjectUrdfText(), "lower=\"-1.2217304764\" upper=\"0.436332312999\"",
                                  "lower=\"1\" upper=\"0.436332312999\"");
  EXPECT_THAT(LoadError(xml), AllOf(HasSubstr("lf_haa_joint"), HasSubstr("lower < upper")));
}

}  // namespace
}  // namespace hyq::dynamics
