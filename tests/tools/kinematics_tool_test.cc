// hyq-kinematics against the dynamics library it reads the model with: the feet's positions,
// contact points and rotations printed for a file of postures equal ForwardKinematics' on the
// same postures (the library itself is checked against MuJoCo in tests/dynamics). The postures:
// the standing one and seeded random ones (random base pose, joints within their limits), in
// hyq-sim's --truth layout with columns the tool must skip.
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynamics/kinematics.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/run_tool.h"

namespace hyq::dynamics {
namespace {

using testing::HyqModel;
using testing::NearRel;

constexpr double kTol = 1e-9;

std::string TempCsv(const std::string& name) {
  return (std::filesystem::path(::testing::TempDir()) / name).string();
}

// Writes the postures with base columns (unless `with_base` is false) and a column that is not
// a posture's between them.
void WritePostures(const std::string& path, const std::vector<VectorQ>& qs, bool with_base) {
  std::ofstream out(path);
  out.precision(17);
  out << "t" << (with_base ? ",x,y,z,qw,qx,qy,qz" : "");
  for (int j = 0; j < kNumJoints; ++j) out << ",q_" << HyqModel().joint_names[j];
  out << ",holding\n";
  for (std::size_t k = 0; k < qs.size(); ++k) {
    out << 0.001 * static_cast<double>(k);
    if (with_base)
      for (int i = 0; i < 7; ++i) out << ',' << qs[k](i);
    for (int j = 0; j < kNumJoints; ++j) out << ',' << qs[k](QIndexOfJoint(j));
    out << ",0\n";
  }
}

struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  double at(std::size_t row, const std::string& column) const {
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == column) return rows.at(row).at(i);
    ADD_FAILURE() << "no column " << column;
    return 0.0;
  }
};

Table ParseCsv(const std::string& text) {
  Table t;
  std::stringstream in(text);
  std::string line, cell;
  std::getline(in, line);
  std::stringstream h(line);
  while (std::getline(h, cell, ',')) t.header.push_back(cell);
  while (std::getline(in, line)) {
    std::stringstream r(line);
    t.rows.emplace_back();
    while (std::getline(r, cell, ',')) t.rows.back().push_back(std::stod(cell));
  }
  return t;
}

std::vector<VectorQ> Postures() {
  std::vector<VectorQ> qs = {HyqModel().StandingQ()};
  std::mt19937_64 rng(7);
  for (int k = 0; k < 5; ++k) qs.push_back(testing::MakeRandomState(HyqModel(), &rng).q);
  return qs;
}

// Runs the tool on `qs` written with base columns (a file named on the command line) or without
// (standard input) and compares each foot's position, contact point and (with --orientation)
// rotation with the library's.
void ExpectFeetOfTheLibrary(const std::vector<VectorQ>& qs, bool with_base, bool orientation) {
  const std::string path = TempCsv(with_base ? "postures.csv" : "joints_only.csv");
  WritePostures(path, qs, with_base);
  const std::string input = with_base ? path : "- < " + path;
  const test::ToolRun run =
      test::RunTool(HYQ_KINEMATICS_TOOL, (orientation ? "--orientation " : "") + input);
  ASSERT_EQ(run.exit_code, 0) << run.out;
  const Table t = ParseCsv(run.out);
  ASSERT_EQ(t.rows.size(), qs.size()) << run.out;
  ASSERT_EQ(t.header.size(), static_cast<std::size_t>(kNumFeet * (orientation ? 15 : 6)));

  Kinematics kin;
  FootKinematics feet;
  for (std::size_t k = 0; k < qs.size(); ++k) {
    ForwardKinematics(HyqModel(), qs[k], VectorV::Zero(), &kin);
    ComputeFootKinematics(HyqModel(), kin, &feet);
    for (int f = 0; f < kNumFeet; ++f) {
      const std::string leg = kLegNames[f];
      const Eigen::Vector3d p(t.at(k, leg + "_x"), t.at(k, leg + "_y"), t.at(k, leg + "_z"));
      const Eigen::Vector3d c(t.at(k, leg + "_cx"), t.at(k, leg + "_cy"), t.at(k, leg + "_cz"));
      const Eigen::Vector3d r_W(0.0, 0.0, HyqModel().feet[f].radius_m);
      EXPECT_TRUE(NearRel(p, feet.p_WF_W[f], kTol)) << "posture " << k << ", " << leg;
      EXPECT_TRUE(NearRel(c, feet.p_WF_W[f] - r_W, kTol)) << "posture " << k << ", " << leg;
      if (!orientation) continue;
      Eigen::Matrix3d R;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) R(i, j) = t.at(k, leg + "_R" + std::to_string(i) + std::to_string(j));
      const Eigen::Matrix3d R_WF = kin.R_WB[HyqModel().feet[f].body] * HyqModel().feet[f].R_BF;
      EXPECT_TRUE(NearRel(R, R_WF, kTol)) << "posture " << k << ", " << leg;
    }
  }
}

TEST(HyqKinematicsTool, FeetEqualTheLibrarysForwardKinematics) {
  ExpectFeetOfTheLibrary(Postures(), true, true);
}

// Without base columns: the base at the origin, not rotated, so the feet are in the trunk frame.
TEST(HyqKinematicsTool, WithoutBaseColumnsTheFeetAreInTheTrunkFrame) {
  std::vector<VectorQ> qs = Postures();
  for (VectorQ& q : qs) q.head<7>() << 0, 0, 0, 1, 0, 0, 0;
  ExpectFeetOfTheLibrary(qs, false, false);
}

TEST(HyqKinematicsTool, AMissingJointColumnIsAUsageError) {
  const std::string path = TempCsv("no_joints.csv");
  std::ofstream(path) << "t,x,y,z\n0,0,0,0.5\n";
  const test::ToolRun run = test::RunTool(HYQ_KINEMATICS_TOOL, path);
  EXPECT_EQ(run.exit_code, 2) << run.out;
  EXPECT_NE(run.out.find("expected a column 'q_lf_haa_joint'"), std::string::npos) << run.out;
}

TEST(HyqKinematicsTool, ABadNumberNamesItsLineAndColumn) {
  std::vector<VectorQ> qs = {HyqModel().StandingQ()};
  const std::string path = TempCsv("bad_number.csv");
  WritePostures(path, qs, true);
  std::ofstream(path, std::ios::app) << "0.002,0,0,0.6,1,0,0,0,fast\n";
  const test::ToolRun run = test::RunTool(HYQ_KINEMATICS_TOOL, path);
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_NE(run.out.find(":3: column 'q_lf_haa_joint': expected a number, found 'fast'"),
            std::string::npos)
      << run.out;
}

}  // namespace
}  // namespace hyq::dynamics
