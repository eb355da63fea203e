// PivotedQr against Eigen's ColPivHouseholderQR (the reference it replaces): the same rank
// decisions, the same projection onto the range, and a complement basis that is orthonormal and
// orthogonal to the range, on the contact ID's shapes (6 × 6 of rank 5, 9 × 6, 12 × 6).
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "servo/control/pivoted_qr.h"

namespace hyq::servo {
namespace {

using Qr = PivotedQr<12, 6>;

// rows × 6 with the given rank, columns of very different scales
Qr::Matrix RandomMatrix(int rows, int rank, std::mt19937_64* rng) {
  std::normal_distribution<double> N;
  Eigen::MatrixXd U(rows, rank), V(rank, 6);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < rank; ++j) U(i, j) = N(*rng);
  for (int i = 0; i < rank; ++i)
    for (int j = 0; j < 6; ++j) V(i, j) = N(*rng) * std::pow(10.0, j % 3);
  return U * V;
}

TEST(PivotedQr, RankAndRangeProjectionAgreeWithEigen) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> N;
  int cases = 0;
  for (int rows : {6, 9, 12}) {
    for (int rank : {4, 5, 6}) {
      for (int t = 0; t < 50; ++t, ++cases) {
        const Qr::Matrix a = RandomMatrix(rows, rank, &rng);
        Qr qr;
        qr.Compute(a, 1e-9);
        Eigen::ColPivHouseholderQR<Eigen::MatrixXd> ref(a);
        ref.setThreshold(1e-9);
        ASSERT_EQ(qr.rank(), ref.rank()) << rows << " × 6 of rank " << rank;
        ASSERT_EQ(qr.rank(), rank);
        // x ← Q diag(I_r, 0) Qᵀ x against Eigen's householder sequence
        Eigen::VectorXd x(rows), y(rows);
        for (int i = 0; i < rows; ++i) x(i) = y(i) = N(rng);
        qr.ApplyQt(x, qr.rank());
        x.tail(rows - qr.rank()).setZero();
        qr.ApplyQ(x, qr.rank());
        y.applyOnTheLeft(ref.householderQ().setLength(ref.rank()).adjoint());
        y.tail(rows - ref.rank()).setZero();
        y.applyOnTheLeft(ref.householderQ().setLength(ref.rank()));
        EXPECT_LT((x - y).norm(), 1e-12 * (1.0 + y.norm()));
        // the projection of a's own columns is a itself
        for (int j = 0; j < 6; ++j) {
          Eigen::VectorXd c = a.col(j);
          qr.ApplyQt(c, qr.rank());
          c.tail(rows - qr.rank()).setZero();
          qr.ApplyQ(c, qr.rank());
          EXPECT_LT((c - a.col(j)).norm(), 1e-11 * a.col(j).norm());
        }
      }
    }
  }
  EXPECT_EQ(cases, 450);
}

TEST(PivotedQr, ComplementIsOrthonormalAndOrthogonalToTheRange) {
  std::mt19937_64 rng(11);
  for (int rows : {3, 6, 9, 12}) {
    for (int rank : {3, 5, 6}) {
      if (rank > rows) continue;
      const Qr::Matrix a = RandomMatrix(rows, rank, &rng);
      Qr qr;
      qr.Compute(a, 1e-9);
      ASSERT_EQ(qr.rank(), rank);
      const int k = rows - qr.rank();
      Eigen::MatrixXd Q = Eigen::MatrixXd::Zero(rows, k);
      Q.bottomRows(k).setIdentity();
      for (int j = 0; j < k; ++j) qr.ApplyQ(Q.col(j), qr.size());
      EXPECT_LT((Q.transpose() * Q - Eigen::MatrixXd::Identity(k, k)).norm(), 1e-13);
      EXPECT_LT((a.transpose() * Q).norm(), 1e-12 * a.norm()) << rows << " × 6 of rank " << rank;
    }
  }
}

TEST(PivotedQr, ZeroAndTinyColumnsGiveRankZeroOrCountOnlyTheLargeOnes) {
  Qr qr;
  qr.Compute(Qr::Matrix::Zero(6, 6), 1e-9);
  EXPECT_EQ(qr.rank(), 0);
  Qr::Matrix a = Qr::Matrix::Zero(6, 6);
  a(0, 0) = 1.0;
  a(1, 3) = 1e-12;  // below 1e-9 of the largest pivot: not rank
  qr.Compute(a, 1e-9);
  EXPECT_EQ(qr.rank(), 1);
}

}  // namespace
}  // namespace hyq::servo
