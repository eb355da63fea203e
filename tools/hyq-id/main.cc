// hyq-id: solves ID problem files (servo/control/id_record.h) line by line.
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <string_view>

#include "dynamics/cycle_dynamics.h"
#include "dynamics/urdf_loader.h"
#include "servo/control/id_record.h"
#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"

namespace {

using namespace hyq;

constexpr std::string_view kUsage =
    "usage: hyq-id [--urdf FILE] [--tangents R] IN.jsonl OUT.jsonl\n"
    "\n"
    "Solves each line of IN.jsonl, an inverse-dynamics problem\n"
    "  {\"q\": [19], \"v\": [18], \"qdd_des\": [12], \"stance\": [4 bools], \"mu\": [4],\n"
    "   \"normal\": [[3] x 4] (optional), \"h\": s, \"controller\": \"two_stage\"|\"stage1\"|\"noslip\"}\n"
    "and writes it to OUT.jsonl with \"result\" added (torques in N m, impulses in N s, stage\n"
    "statuses, kinetic energy, fallback). A bad line is reported on stderr with its line number\n"
    "and skipped (so is a line over 1 MiB); the others are still solved. Consecutive lines warm-start the QPs, as in the\n"
    "servo loop. OUT.jsonl may be - for standard output.\n"
    "\n"
    "  --urdf FILE    the robot model (default: @config@/robots/hyq.urdf)\n"
    "  --tangents R   friction directions per contact, 1..8 (default 4)\n"
    "  --help         this text\n"
    "\n"
    "exit status: 0 all lines solved, 1 some lines bad or a solve fell back, 2 usage or I/O error\n";

const char* Kind(std::filesystem::file_type t) {
  switch (t) {
    case std::filesystem::file_type::directory: return "a directory";
    case std::filesystem::file_type::character: return "a character device";
    case std::filesystem::file_type::block: return "a block device";
    case std::filesystem::file_type::socket: return "a socket";
    case std::filesystem::file_type::not_found: return "nothing (no such file)";
    default: return "not a regular file";
  }
}

// An empty string when `path` is a file to read (regular, or a pipe when `pipe_ok`), else why
// not: /dev/zero would never end and a directory reads as an empty file.
std::string NotAFile(const std::string& path, bool pipe_ok) {
  std::error_code ec;
  const auto t = std::filesystem::status(path, ec).type();
  if (t == std::filesystem::file_type::regular ||
      (pipe_ok && t == std::filesystem::file_type::fifo))
    return {};
  return path + ": expected a regular file, found " + Kind(t);
}

// std::getline, but a line longer than `max` is skipped to its end (*too_long set) rather than
// held in memory whole.
bool ReadLine(std::istream& in, std::size_t max, std::string* line, bool* too_long) {
  line->clear();
  *too_long = false;
  std::streambuf* buf = in.rdbuf();
  for (;;) {
    const int c = buf->sbumpc();
    if (c == std::char_traits<char>::eof()) return !line->empty() || *too_long;
    if (c == '\n') return true;
    if (line->size() < max) {
      line->push_back(static_cast<char>(c));
    } else {
      *too_long = true;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string urdf = hyq::cli::DefaultUrdf(), in_path, out_path;
  int tangents = 4;
  hyq::cli::CommandLine cl(argc, argv, "hyq-id", hyq::cli::WithPaths(std::string(kUsage)));
  while (cl.Next()) {
    if (cl.Flag("--urdf")) {
      urdf = cl.Value();
    } else if (cl.Flag("--tangents")) {
      tangents = static_cast<int>(cl.Integer(1, servo::kMaxTangents));
    } else if (cl.IsOption()) {
      cl.Unknown();
    } else if (in_path.empty()) {
      in_path = cl.arg();
    } else if (out_path.empty()) {
      out_path = cl.arg();
    } else {
      cl.Fail("expected two files, found a third: '" + cl.arg() + "'");
    }
  }
  if (out_path.empty()) cl.Fail("expected IN.jsonl and OUT.jsonl");

  // the loader reads the whole file into memory: --urdf /dev/zero would end in bad_alloc
  if (const std::string why = NotAFile(urdf, false); !why.empty()) {
    std::fprintf(stderr, "hyq-id: --urdf %s\n", why.c_str());
    return 2;
  }
  dynamics::Model model;
  try {
    model = dynamics::LoadModelFromUrdf(urdf);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hyq-id: %s\n", e.what());
    return 2;
  }
  if (const std::string why = NotAFile(in_path, true); !why.empty()) {
    std::fprintf(stderr, "hyq-id: %s\n", why.c_str());
    return 2;
  }
  std::ifstream in(in_path);
  if (!in) {
    std::fprintf(stderr, "hyq-id: %s: cannot open for reading\n", in_path.c_str());
    return 2;
  }
  std::ofstream out_file;
  if (out_path != "-") {
    out_file.open(out_path);
    if (!out_file) {
      std::fprintf(stderr, "hyq-id: %s: cannot open for writing\n", out_path.c_str());
      return 2;
    }
  }
  std::ostream& out = out_path == "-" ? std::cout : out_file;

  servo::TwoStageSettings two;
  two.tangent_directions = tangents;
  servo::TwoStageSettings one = two;
  one.stage2 = false;
  servo::TwoStageId two_stage(two), stage1(one);
  servo::NoSlipId noslip;
  auto dyn = std::make_unique<dynamics::CycleDynamics>();

  long line_no = 0, solved = 0, bad = 0, fallbacks = 0;
  std::string line;
  bool too_long = false;
  const auto t0 = std::chrono::steady_clock::now();
  while (ReadLine(in, servo::kMaxIdRecordBytes, &line, &too_long)) {
    ++line_no;
    if (too_long) {
      std::fprintf(stderr, "%s:%ld: expected a line of at most %zu bytes, found a longer one\n",
                   in_path.c_str(), line_no, servo::kMaxIdRecordBytes);
      ++bad;
      continue;
    }
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    servo::IdRecord rec;
    try {
      rec = servo::ParseIdRecord(line);
    } catch (const std::exception& e) {  // IdRecordError; anything else is reported the same way
      std::fprintf(stderr, "%s:%ld: %s\n", in_path.c_str(), line_no, e.what());
      ++bad;
      continue;
    }
    if (dynamics::ComputeCycleDynamics(model, rec.input.q, rec.input.v, dyn.get()) !=
        dynamics::DynamicsStatus::kOk) {
      std::fprintf(stderr, "%s:%ld: the state (q, v) is not usable by the dynamics\n",
                   in_path.c_str(), line_no);
      ++bad;
      continue;
    }
    servo::IdOutput result;
    servo::IdStatus st = servo::IdStatus::kBadInput;
    switch (rec.controller) {
      case servo::ControllerKind::kTwoStageId: st = two_stage.Solve(model, *dyn, rec.input, &result); break;
      case servo::ControllerKind::kStage1Id: st = stage1.Solve(model, *dyn, rec.input, &result); break;
      case servo::ControllerKind::kNoSlipId: st = noslip.Solve(model, *dyn, rec.input, &result); break;
      case servo::ControllerKind::kPid:
      case servo::ControllerKind::kPdGravity: break;
    }
    if (st != servo::IdStatus::kOk) {
      ++fallbacks;
      std::fprintf(stderr, "%s:%ld: %s (fallback: %s)\n", in_path.c_str(), line_no,
                   servo::ToString(st), servo::ToString(result.fallback));
    }
    out << servo::FormatIdRecord(rec, &result) << '\n';
    ++solved;
    if (solved % 10000 == 0) std::fprintf(stderr, "\rhyq-id: %ld lines solved", solved);
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(stderr, "%shyq-id: %ld solved (%ld fell back), %ld bad line(s), %.3f s\n",
               solved >= 10000 ? "\n" : "", solved, fallbacks, bad, s);
  // a full disk (or /dev/full) must not pass for success: the results are lost
  out.flush();
  if (!out) {
    std::fprintf(stderr, "hyq-id: %s: writing the results failed (disk full or an I/O error)\n",
                 out_path.c_str());
    return 2;
  }
  return (bad > 0 || fallbacks > 0) ? 1 : 0;
}
