#include "hal/spsc_ring.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <stdexcept>
#include <thread>

#include "tests/support/no_heap_guard.h"

namespace hyq::hal {
namespace {

TEST(SpscRing, RejectsCapacityNotPowerOfTwo) {
  EXPECT_THROW(SpscRing<int>(0), std::invalid_argument);
  EXPECT_THROW(SpscRing<int>(1), std::invalid_argument);
  EXPECT_THROW(SpscRing<int>(12), std::invalid_argument);
  EXPECT_NO_THROW(SpscRing<int>(16));
}

TEST(SpscRing, FifoFullAndEmpty) {
  SpscRing<int> ring(4);
  int out = -1;
  EXPECT_FALSE(ring.TryPop(&out));
  EXPECT_EQ(out, -1);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(ring.TryPush(i));
  EXPECT_FALSE(ring.TryPush(99));  // full: nothing stored
  EXPECT_EQ(ring.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(ring.TryPop(&out));
    EXPECT_EQ(out, i);
  }
  EXPECT_FALSE(ring.TryPop(&out));
  EXPECT_TRUE(ring.empty());
}

TEST(SpscRing, WrapsAroundManyTimes) {
  SpscRing<std::uint64_t> ring(8);
  std::uint64_t next_in = 0, next_out = 0, out = 0;
  for (int round = 0; round < 1000; ++round) {
    for (int k = 0; k < 1 + round % 8; ++k) ASSERT_TRUE(ring.TryPush(next_in++));
    while (ring.TryPop(&out)) ASSERT_EQ(out, next_out++);
  }
  EXPECT_EQ(next_in, next_out);
}

TEST(SpscRing, IndicesOnSeparateCacheLines) {
  // the producer's and consumer's indices must not share a line (false sharing)
  EXPECT_GE(sizeof(SpscRing<int>), 3 * kCacheLineBytes);
  EXPECT_EQ(alignof(SpscRing<int>), kCacheLineBytes);
}

TEST(SpscRing, NoHeapInPushPop) {
  HYQ_REQUIRE_HEAP_HOOKS();
  SpscRing<std::array<double, 64>> ring(16);
  std::array<double, 64> v{}, out{};
  hyq::testing::NoHeapGuard guard;
  for (int i = 0; i < 100; ++i) {
    v[0] = i;
    ASSERT_TRUE(ring.TryPush(v));
    ASSERT_TRUE(ring.TryPop(&out));
  }
  EXPECT_EQ(guard.allocations(), 0u);
}

// Two threads, a small ring so that it is full and empty often: every element arrives once, in
// order, intact (a torn element would break the checksum).
TEST(SpscRing, TwoThreadStress) {
  struct Item {
    std::uint64_t seq = 0;
    std::array<std::uint64_t, 7> payload{};
  };
  constexpr std::uint64_t kCount = 2'000'000;
  SpscRing<Item> ring(64);
  std::uint64_t full_spins = 0;
  std::thread producer([&] {
    Item item;
    for (std::uint64_t i = 0; i < kCount; ++i) {
      item.seq = i;
      for (std::size_t k = 0; k < item.payload.size(); ++k) item.payload[k] = i * 31 + k;
      while (!ring.TryPush(item)) ++full_spins;
    }
  });
  std::uint64_t expected = 0, empty_spins = 0;
  Item out;
  while (expected < kCount) {
    if (!ring.TryPop(&out)) {
      ++empty_spins;
      continue;
    }
    ASSERT_EQ(out.seq, expected);
    for (std::size_t k = 0; k < out.payload.size(); ++k) ASSERT_EQ(out.payload[k], expected * 31 + k);
    ++expected;
  }
  producer.join();
  EXPECT_TRUE(ring.empty());
  std::printf("stress: %llu items, producer saw full %llu times, consumer saw empty %llu times\n",
              static_cast<unsigned long long>(kCount), static_cast<unsigned long long>(full_spins),
              static_cast<unsigned long long>(empty_spins));
}

}  // namespace
}  // namespace hyq::hal
