// The allocation guard must be able to fail: these tests show that it sees every kind of
// allocation the real-time code could make, so a zero from it means something.
#include "tests/support/no_heap_guard.h"

#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

namespace hyq::testing {
namespace {

TEST(NoHeapGuard, SeesOperatorNew) {
  HYQ_REQUIRE_HEAP_HOOKS();
  NoHeapGuard guard;
  auto p = std::make_unique<int>(3);
  EXPECT_EQ(guard.allocations(), 1u);
}

TEST(NoHeapGuard, SeesMallocAndVectorGrowth) {
  HYQ_REQUIRE_HEAP_HOOKS();
  NoHeapGuard guard;
  void* volatile p = std::malloc(16);  // volatile: the compiler may not elide the pair
  std::free(p);
  std::vector<double> v;
  v.push_back(1.0);
  EXPECT_GE(guard.allocations(), 2u);
  EXPECT_GE(guard.deallocations(), 1u);
}

TEST(NoHeapGuard, SeesDynamicEigen) {
  HYQ_REQUIRE_HEAP_HOOKS();
  Eigen::MatrixXd a = Eigen::MatrixXd::Identity(4, 4);
  NoHeapGuard guard;
  Eigen::MatrixXd b = a * a;
  EXPECT_GE(guard.allocations(), 1u);
}

TEST(NoHeapGuard, QuietForFixedSizeWork) {
  HYQ_REQUIRE_HEAP_HOOKS();
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Identity();
  NoHeapGuard guard;
  Eigen::Matrix<double, 6, 6> b = a * a + a;
  EXPECT_EQ(guard.allocations(), 0u) << b.sum();
}

TEST(NoHeapGuard, Nests) {
  HYQ_REQUIRE_HEAP_HOOKS();
  NoHeapGuard outer;
  { NoHeapGuard inner; }
  auto p = std::make_unique<int>(1);
  EXPECT_EQ(outer.allocations(), 1u);
}

}  // namespace
}  // namespace hyq::testing
