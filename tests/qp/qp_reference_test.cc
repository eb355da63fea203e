// qp/ against a second solver: every instance of tests/qp/data/reference.json (written by
// tests/qp/data/make_reference.py with Debian's python3-cvxopt, an interior-point method) is
// solved here and compared with cvxopt's answer: the status; for optimal ones the objective and,
// where H is positive definite, x; and our KKT residuals; for infeasible ones our certificate.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "qp/solver.h"
#include "tests/qp/qp_test_problems.h"
#include "tests/support/paths.h"

namespace hyq::qp {
namespace {

using nlohmann::json;

double Number(const json& v, double if_null) { return v.is_null() ? if_null : v.get<double>(); }

// H = Fᵀ F, g = Fᵀ c + g0 (see make_reference.py)
Problem FromJson(const json& d) {
  const int n = d.at("n"), m = d.at("m");
  Problem p;
  p.Resize(n, m);
  for (int i = 0; i < n; ++i) {
    p.g(i) = d.at("g0")[i].get<double>();
    p.lb(i) = Number(d.at("lb")[i], -kInf);
    p.ub(i) = Number(d.at("ub")[i], kInf);
  }
  for (int k = 0; k < m; ++k) {
    for (int j = 0; j < n; ++j) p.A(k, j) = d.at("A")[k][j].get<double>();
    p.lbA(k) = Number(d.at("lbA")[k], -kInf);
    p.ubA(k) = Number(d.at("ubA")[k], kInf);
  }
  if (d.contains("F")) {
    const int rows = static_cast<int>(d.at("F").size());
    Eigen::MatrixXd F(rows, n);
    for (int r = 0; r < rows; ++r)
      for (int j = 0; j < n; ++j) F(r, j) = d.at("F")[r][j].get<double>();
    const Eigen::MatrixXd H = F.transpose() * F;
    p.H = 0.5 * (H + H.transpose());
    if (d.contains("c")) {
      Eigen::VectorXd c(rows);
      for (int r = 0; r < rows; ++r) c(r) = d.at("c")[r].get<double>();
      p.g += F.transpose() * c;
    }
  }
  return p;
}

TEST(QpReference, AgreesWithCvxoptOnEverySavedInstance) {
  const std::string path = (hyq::testing::SourceDir() / "tests/qp/data/reference.json").string();
  std::ifstream in(path);
  ASSERT_TRUE(in) << "cannot open " << path;
  const json root = json::parse(in);
  const json& instances = root.at("instances");
  ASSERT_GE(instances.size(), 200u);
  Solver solver;
  int optimal = 0, infeasible = 0, compared_x = 0, id_shaped = 0, worst_iterations = 0;
  for (const json& d : instances) {
    const std::string name = d.at("name");
    const Problem p = FromJson(d);
    Solution s;
    const Status st = solver.Solve(p, Budget{}, &s);
    worst_iterations = std::max(worst_iterations, s.iterations);
    if (d.at("status") == "infeasible") {
      ++infeasible;
      EXPECT_EQ(st, Status::kInfeasible) << name;
      if (st == Status::kInfeasible) {
        EXPECT_TRUE(testing::IsFarkasCertificate(p, s)) << name;
      }
      continue;
    }
    ++optimal;
    id_shaped += name.rfind("id_", 0) == 0;
    ASSERT_EQ(st, Status::kOptimal) << name << " kkt " << s.kkt.max();
    EXPECT_LE(s.kkt.max(), 1e-9) << name;
    const double f_ref = d.at("objective");
    EXPECT_LE(std::fabs(s.objective - f_ref), 1e-7 * std::max(1.0, std::fabs(f_ref)))
        << name << ": ours " << s.objective << ", cvxopt " << f_ref;
    if (d.at("unique")) {
      ++compared_x;
      double err = 0.0, scale = 1.0;
      for (int i = 0; i < p.n(); ++i) {
        err = std::max(err, std::fabs(s.x(i) - d.at("x")[i].get<double>()));
        scale = std::max(scale, std::fabs(s.x(i)));
      }
      EXPECT_LE(err, 1e-5 * scale) << name;
    }
  }
  EXPECT_GE(id_shaped, 30);
  EXPECT_GE(infeasible, 10);
  RecordProperty("optimal", optimal);
  RecordProperty("infeasible", infeasible);
  RecordProperty("x_compared", compared_x);
  RecordProperty("worst_iterations", worst_iterations);
  std::printf("%d optimal (%d ID-shaped, x compared on %d), %d infeasible; worst %d iterations\n",
              optimal, id_shaped, compared_x, infeasible, worst_iterations);
}

// A problem in hyq-qp-solve's format: H, g, and optionally A, lbA, ubA, lb, ub (null = ±∞).
Problem FromToolJson(const json& d) {
  const int n = static_cast<int>(d.at("g").size());
  const int m = d.contains("A") ? static_cast<int>(d.at("A").size()) : 0;
  Problem p;
  p.Resize(n, m);
  for (int i = 0; i < n; ++i) {
    p.g(i) = d.at("g")[i].get<double>();
    for (int j = 0; j < n; ++j) p.H(i, j) = d.at("H")[i][j].get<double>();
    if (d.contains("lb")) p.lb(i) = Number(d.at("lb")[i], -kInf);
    if (d.contains("ub")) p.ub(i) = Number(d.at("ub")[i], kInf);
  }
  for (int k = 0; k < m; ++k) {
    for (int j = 0; j < n; ++j) p.A(k, j) = d.at("A")[k][j].get<double>();
    p.lbA(k) = Number(d.at("lbA")[k], -kInf);
    p.ubA(k) = Number(d.at("ubA")[k], kInf);
  }
  return p;
}

// The QPs captured from the two-stage contact inverse dynamics (tests/qp/data/contact_id/,
// Stage I "stage1_*", the rest Stage II: rows P w ≥ −z with many z exactly 0, so w = 0 is
// feasible with many rows active at zero slack). All are feasible (cvxopt: optimal); the solver
// used to return "infeasible" on five of them (a Farkas "certificate" whose gap was not
// negative). Every one must be optimal, with KKT residuals ≤ 1e-9, cold and warm, and its
// objective must agree with cvxopt's (answers.json, written by make_reference.py).
TEST(QpReference, ContactIdInstancesAreOptimalAndAgreeWithCvxopt) {
  const std::filesystem::path folder = hyq::testing::SourceDir() / "tests/qp/data/contact_id";
  std::ifstream answers_in(folder / "answers.json");
  ASSERT_TRUE(answers_in) << "cannot open " << (folder / "answers.json");
  std::map<std::string, json> answers;
  const json answers_root = json::parse(answers_in);
  for (const json& a : answers_root.at("answers")) answers[a.at("file").get<std::string>()] = a;
  int files = 0, stage1 = 0, worst_iterations = 0;
  double worst_kkt = 0.0, worst_objective = 0.0;
  Solver solver;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() != ".json" || name == "answers.json") continue;
    ++files;
    stage1 += name.rfind("stage1_", 0) == 0;
    ASSERT_TRUE(answers.count(name)) << name << " has no cvxopt answer: run make_reference.py";
    const json& ref = answers.at(name);
    ASSERT_EQ(ref.at("default").at("status"), "optimal") << name;
    std::ifstream in(entry.path());
    const Problem p = FromToolJson(json::parse(in));
    Solution s;
    const Status st = solver.Solve(p, Budget{}, &s);
    ASSERT_EQ(st, Status::kOptimal) << name << ": " << ToString(st) << ", kkt " << s.kkt.max();
    const KktResiduals r = ComputeKktResiduals(p, s.x, s.y_bounds, s.y_constraints);
    EXPECT_LE(r.max(), 1e-9) << name;
    EXPECT_LE(s.kkt.max(), 1e-9) << name;
    worst_kkt = std::max(worst_kkt, r.max());
    worst_iterations = std::max(worst_iterations, s.iterations);
    // cvxopt's default tolerances (abstol 1e-7) and its tight run (feasible to ~1e-11)
    const double f_default = ref.at("default").at("objective");
    const double f_tight = ref.at("tight").at("objective");
    EXPECT_LE(std::fabs(s.objective - f_default), 1e-7 * std::max(1.0, std::fabs(f_default)))
        << name << ": ours " << s.objective << ", cvxopt " << f_default;
    EXPECT_LE(std::fabs(s.objective - f_tight), 1e-9 * std::max(1.0, std::fabs(f_tight)))
        << name << ": ours " << s.objective << ", cvxopt (tight) " << f_tight;
    worst_objective = std::max(worst_objective, std::fabs(s.objective - f_tight));
    // the servo re-solves warm: the same problem again, from this answer
    Budget warm;
    warm.warm_start = true;
    Solution s2 = s;
    EXPECT_EQ(solver.Solve(p, warm, &s2), Status::kOptimal) << name << " (warm)";
    EXPECT_LE(s2.kkt.max(), 1e-9) << name << " (warm)";
  }
  EXPECT_EQ(files, static_cast<int>(answers.size())) << "answers.json lists files that are gone";
  EXPECT_GE(files, 28);
  EXPECT_GE(stage1, 1);
  std::printf("%d contact-ID instances optimal; worst kkt %.1e, worst |f - f_cvxopt| %.1e, "
              "worst %d iterations\n",
              files, worst_kkt, worst_objective, worst_iterations);
}

}  // namespace
}  // namespace hyq::qp
