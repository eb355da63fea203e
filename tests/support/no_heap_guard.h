// Proof that a real-time path does not touch the heap.
//
// Linking tests/support/no_heap_guard.cc into a test executable replaces malloc, calloc, realloc,
// aligned_alloc, posix_memalign and every operator new with versions that count calls made by the
// current thread while a NoHeapGuard is alive. A test wraps the code under test in a guard and
// asserts that the count is zero:
//
//   Crba(model, &data);                       // warm-up, may allocate
//   { NoHeapGuard guard; Crba(model, &data); EXPECT_EQ(guard.allocations(), 0); }
//
// To find an allocation, run the test with HYQ_NO_HEAP_ABORT=1 under gdb: the guarded
// allocation aborts and the backtrace shows its caller.
//
// The guard is per thread, so gtest's own bookkeeping in other threads does not count. Under the
// sanitizers (which replace the allocator themselves) the hooks are compiled out and
// NoHeapGuard::Available() is false: tests must skip with that reason printed.
#pragma once

#include <cstddef>

namespace hyq::testing {

class NoHeapGuard {
 public:
  NoHeapGuard() noexcept;
  ~NoHeapGuard();
  NoHeapGuard(const NoHeapGuard&) = delete;
  NoHeapGuard& operator=(const NoHeapGuard&) = delete;

  /// Heap allocations (malloc family and operator new) by this thread since construction.
  std::size_t allocations() const noexcept;
  /// Calls to free / operator delete by this thread since construction.
  std::size_t deallocations() const noexcept;

  /// False when the allocator hooks are compiled out (sanitizer builds).
  static bool Available() noexcept;

 private:
  std::size_t alloc_start_;
  std::size_t free_start_;
  bool outer_active_;
};

}  // namespace hyq::testing

/// Skips the current test, printing why, when allocations cannot be observed in this build.
#define HYQ_REQUIRE_HEAP_HOOKS()                                                            \
  do {                                                                                      \
    if (!::hyq::testing::NoHeapGuard::Available())                                          \
      GTEST_SKIP() << "allocator hooks are compiled out in sanitizer builds; the release, " \
                      "dev and ci presets run this test";                                   \
  } while (false)
