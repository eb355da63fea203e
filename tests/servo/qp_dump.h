// Writes a qp::Problem in hyq-qp-solve's JSON format (for regression instances).
#pragma once

#include <cmath>
#include <fstream>
#include <string>

#include "qp/problem.h"

namespace hyq::testing {

inline void DumpQpJson(const qp::Problem& p, const std::string& path) {
  std::ofstream f(path);
  f.precision(17);
  auto mat = [&](const auto& M) {
    f << "[";
    for (int i = 0; i < M.rows(); ++i) {
      f << (i ? "," : "") << "[";
      for (int j = 0; j < M.cols(); ++j) f << (j ? "," : "") << M(i, j);
      f << "]";
    }
    f << "]";
  };
  auto vec = [&](const auto& v) {
    f << "[";
    for (int i = 0; i < v.size(); ++i) {
      f << (i ? "," : "");
      if (std::isinf(v(i))) f << "null"; else f << v(i);
    }
    f << "]";
  };
  f << "{\"H\":";
  mat(p.H);
  f << ",\"g\":";
  vec(p.g);
  f << ",\"A\":";
  mat(p.A);
  f << ",\"lbA\":";
  vec(p.lbA);
  f << ",\"ubA\":";
  vec(p.ubA);
  f << ",\"lb\":";
  vec(p.lb);
  f << ",\"ub\":";
  vec(p.ub);
  f << "}\n";
}

}  // namespace hyq::testing
