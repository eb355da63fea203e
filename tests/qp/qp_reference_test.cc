// qp/ against a second solver: every instance of tests/qp/data/reference.json (written by
// tests/qp/data/make_reference.py with Debian's python3-cvxopt, an interior-point method) is
// solved here and compared with cvxopt's answer: the status; for optimal ones the objective and,
// where H is positive definite, x; and our KKT residuals; for infeasible ones our certificate.
#include <cmath>
#include <fstream>
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

}  // namespace
}  // namespace hyq::qp
