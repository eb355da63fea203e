// hyq-kinematics: the feet's positions (and orientations) for each posture of a CSV file, from
// the project's dynamics library (ForwardKinematics, ComputeFootKinematics), so that scripts
// which need foot positions use the servo's own model instead of re-deriving the leg's chain.
#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "dynamics/kinematics.h"
#include "dynamics/urdf_loader.h"
#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"

namespace {

using namespace hyq::dynamics;

constexpr std::string_view kUsage =
    "usage: hyq-kinematics [--urdf FILE] [--orientation] [CSV]\n"
    "\n"
    "Reads postures from CSV (default or '-': standard input), a comma-separated file with a\n"
    "header naming its columns, e.g. hyq-sim's --truth file:\n"
    "  q_<joint>         the twelve joint angles (rad), joints named as in the URDF\n"
    "                    (q_lf_haa_joint, ...); required\n"
    "  x,y,z             the base position in the world (m); optional, default 0\n"
    "  qw,qx,qy,qz       the base orientation, a quaternion; optional, default the identity\n"
    "Other columns are ignored. Writes one CSV line per posture to standard output, in order:\n"
    "  <leg>_x,<leg>_y,<leg>_z      the centre of the leg's foot sphere (world, m)\n"
    "  <leg>_cx,<leg>_cy,<leg>_cz   the sphere's lowest point, where it touches level ground:\n"
    "                               the centre minus the foot radius along world z (m)\n"
    "  <leg>_R00 .. <leg>_R22      with --orientation: the foot frame's rotation R_WF, row by\n"
    "                               row (the frame is fixed to the lower leg)\n"
    "for the legs lf, rf, lh, rh. Without base columns the positions are in the trunk's frame.\n"
    "\n"
    "  --urdf FILE     the robot model (default: @config@/robots/hyq.urdf)\n"
    "  --orientation   also the feet's rotations\n"
    "  --help          this text\n"
    "\n"
    "exit status: 0 done, 1 a malformed line (named on stderr), 2 usage, model or I/O error\n";

[[noreturn]] void Fail(int status, const std::string& msg) {
  std::fprintf(stderr, "hyq-kinematics: %s\n", msg.c_str());
  std::exit(status);
}

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(cell);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

// The index of column `name` in the header, or -1.
int ColumnOf(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  return -1;
}

struct Options {
  std::string urdf = hyq::cli::DefaultUrdf();
  std::string input = "-";
  bool orientation = false;
};

Options ParseOptions(int argc, char** argv) {
  Options o;
  bool have_input = false;
  hyq::cli::CommandLine cl(argc, argv, "hyq-kinematics", hyq::cli::WithPaths(std::string(kUsage)));
  while (cl.Next()) {
    if (cl.Flag("--orientation")) o.orientation = true;
    else if (cl.Flag("--urdf")) o.urdf = cl.Value();
    else if (cl.IsOption()) cl.Unknown();
    else if (!have_input) {
      o.input = cl.arg();
      have_input = true;
    } else {
      cl.Bad("CSV", "one input file", cl.arg());
    }
  }
  return o;
}

// Where each input column of a posture is: the joints' (required) and the base pose's (-1 where
// absent; the quaternion all or none).
struct PostureColumns {
  std::vector<std::string> header;
  std::array<int, kNumJoints> joint{};
  std::array<int, 7> base{};  // x, y, z, qw, qx, qy, qz
  bool quaternion = false;
};

PostureColumns ReadHeader(const Model& model, const std::string& source, std::istream& in) {
  std::string line;
  if (!std::getline(in, line)) Fail(2, source + ": expected a header line, found an empty file");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  PostureColumns c;
  c.header = SplitCsv(line);
  for (int j = 0; j < kNumJoints; ++j) {
    c.joint[j] = ColumnOf(c.header, "q_" + model.joint_names[j]);
    if (c.joint[j] < 0)
      Fail(2, source + ": expected a column 'q_" + model.joint_names[j] + "' in the header, found '" +
                  line.substr(0, 200) + "'");
  }
  constexpr std::array<const char*, 7> kBaseNames = {"x", "y", "z", "qw", "qx", "qy", "qz"};
  int quaternion_columns = 0;
  for (int i = 0; i < 7; ++i) {
    c.base[i] = ColumnOf(c.header, kBaseNames[i]);
    if (i >= 3 && c.base[i] >= 0) ++quaternion_columns;
  }
  if (quaternion_columns != 0 && quaternion_columns != 4)
    Fail(2, source + ": expected all of the columns qw, qx, qy, qz or none of them");
  c.quaternion = quaternion_columns == 4;
  return c;
}

// The posture of one line: the base at the origin and not rotated where its columns are absent.
VectorQ ParsePosture(const PostureColumns& c, const std::string& where, const std::string& line) {
  const std::vector<std::string> cells = SplitCsv(line);
  auto value = [&](int col) {
    if (col >= static_cast<int>(cells.size()))
      Fail(1, where + ": expected " + std::to_string(c.header.size()) + " columns, found " +
                  std::to_string(cells.size()));
    char* end = nullptr;
    const double x = std::strtod(cells[col].c_str(), &end);
    if (cells[col].empty() || *end != '\0')
      Fail(1, where + ": column '" + c.header[col] + "': expected a number, found '" + cells[col] + "'");
    return x;
  };
  VectorQ q = VectorQ::Zero();
  q(3) = 1.0;
  for (int i = 0; i < 3; ++i)
    if (c.base[i] >= 0) q(i) = value(c.base[i]);
  if (c.quaternion)
    for (int i = 3; i < 7; ++i) q(i) = value(c.base[i]);
  for (int j = 0; j < kNumJoints; ++j) q(QIndexOfJoint(j)) = value(c.joint[j]);
  if (q.segment<4>(3).norm() < 1e-6) Fail(1, where + ": expected a non-zero quaternion");
  return q;
}

void WriteHeader(bool orientation) {
  std::string out;
  for (const char* leg : kLegNames) {
    for (const char* c : {"_x", "_y", "_z", "_cx", "_cy", "_cz"}) out += std::string(leg) + c + ",";
    if (orientation)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) out += std::string(leg) + "_R" + std::to_string(r) + std::to_string(c) + ",";
  }
  out.back() = '\n';
  std::fputs(out.c_str(), stdout);
}

// p_WF, the sphere's lowest point p_WF - r z_W, and (with `orientation`) R_WF of every foot.
void WriteFeet(const Model& model, const VectorQ& q, bool orientation, Kinematics* kin,
               FootKinematics* feet) {
  ForwardKinematics(model, q, VectorV::Zero(), kin);
  ComputeFootKinematics(model, *kin, feet);
  for (int f = 0; f < kNumFeet; ++f) {
    const Eigen::Vector3d& p = feet->p_WF_W[f];
    const double r = model.feet[f].radius_m;
    std::printf("%.12g,%.12g,%.12g,%.12g,%.12g,%.12g", p.x(), p.y(), p.z(), p.x(), p.y(), p.z() - r);
    if (orientation) {
      const Eigen::Matrix3d R_WF = kin->R_WB[model.feet[f].body] * model.feet[f].R_BF;
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) std::printf(",%.12g", R_WF(i, k));
    }
    std::putchar(f + 1 < kNumFeet ? ',' : '\n');
  }
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = ParseOptions(argc, argv);
  Model model;
  try {
    model = LoadModelFromUrdf(o.urdf);
  } catch (const ModelError& e) {
    Fail(2, e.what());
  }
  std::ifstream file;
  if (o.input != "-") {
    file.open(o.input);
    if (!file) Fail(2, "cannot read '" + o.input + "'");
  }
  std::istream& in = o.input == "-" ? std::cin : file;
  const std::string source = o.input == "-" ? "standard input" : o.input;

  const PostureColumns columns = ReadHeader(model, source, in);
  WriteHeader(o.orientation);
  Kinematics kin;
  FootKinematics feet;
  std::string line;
  for (long line_number = 2; std::getline(in, line); ++line_number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const VectorQ q = ParsePosture(columns, source + ":" + std::to_string(line_number), line);
    WriteFeet(model, q, o.orientation, &kin, &feet);
  }
  if (in.bad()) Fail(2, source + ": read error");
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) Fail(2, "cannot write standard output");
  return 0;
}
