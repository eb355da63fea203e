// Bounded lock-free single-producer / single-consumer ring (Lamport's queue with acquire/release
// indices, as in Rigtorp's SPSCQueue and folly::ProducerConsumerQueue).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace hyq::hal {

/// Cache-line size used to keep the producer's and the consumer's indices apart.
inline constexpr std::size_t kCacheLineBytes = 64;

/// A ring of `capacity` slots (a power of two) for exactly one producer thread and one consumer
/// thread. The storage is allocated once, by the constructor; TryPush and TryPop never allocate,
/// lock, block or throw, and each finishes in a bounded number of steps (wait-free).
///
/// Indices count up forever (64 bits do not wrap in practice); slot = index & (capacity − 1). The
/// producer publishes a slot by storing tail_ with release after writing it; the consumer reads
/// tail_ with acquire before reading the slot, and frees it by storing head_ with release. Each
/// side keeps a cached copy of the other side's index so that the shared line is read only when
/// the ring looks full (producer) or empty (consumer).
template <class T>
class SpscRing {
  static_assert(std::is_nothrow_copy_assignable_v<T> && std::is_nothrow_default_constructible_v<T>,
                "SpscRing elements are copied in and out without throwing");

 public:
  /// @throws std::invalid_argument unless capacity is a power of two ≥ 2.
  explicit SpscRing(std::size_t capacity)
      : capacity_(capacity), mask_(capacity - 1) {
    if (capacity < 2 || (capacity & (capacity - 1)) != 0)
      throw std::invalid_argument("SpscRing: capacity must be a power of two >= 2, found " +
                                  std::to_string(capacity));
    slots_ = std::make_unique<T[]>(capacity);
  }
  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  /// Producer: copies `value` into the ring; false (and nothing stored) when it is full.
  bool TryPush(const T& value) noexcept {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail - head_cache_ >= capacity_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail - head_cache_ >= capacity_) return false;
    }
    slots_[tail & mask_] = value;
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Consumer: moves the oldest element into *out; false (and *out untouched) when empty.
  bool TryPop(T* out) noexcept {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_cache_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head == tail_cache_) return false;
    }
    *out = slots_[head & mask_];
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  /// Elements queued; exact on either side's own thread when the other side is idle, otherwise a
  /// snapshot.
  std::size_t size() const noexcept {
    const std::uint64_t head = head_.load(std::memory_order_acquire);
    const std::uint64_t tail = tail_.load(std::memory_order_acquire);
    return static_cast<std::size_t>(tail - head);
  }
  bool empty() const noexcept { return size() == 0; }
  std::size_t capacity() const noexcept { return capacity_; }

 private:
  const std::size_t capacity_;
  const std::size_t mask_;
  std::unique_ptr<T[]> slots_;

  // consumer's line: its index and its copy of the producer's
  alignas(kCacheLineBytes) std::atomic<std::uint64_t> head_{0};
  std::uint64_t tail_cache_ = 0;
  // producer's line
  alignas(kCacheLineBytes) std::atomic<std::uint64_t> tail_{0};
  std::uint64_t head_cache_ = 0;
  // nothing after tail_'s line shares it
  alignas(kCacheLineBytes) char pad_[1] = {};
};

}  // namespace hyq::hal
