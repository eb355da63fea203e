#include "drivers/shm_channel.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <type_traits>

#include "drivers/channel_error.h"

namespace hyq::drivers {
namespace internal {

constexpr std::uint32_t kShmMagic = 0x48594353;  // "HYCS"
constexpr std::uint32_t kShmVersion = 1;

struct ShmRing {
  alignas(64) std::atomic<std::uint64_t> tail;  // frames written (the producer's)
  alignas(64) std::atomic<std::uint64_t> head;  // frames read (the consumer's)
  alignas(64) hal::CanFrame frames[kShmRingFrames];
};

struct ShmBusSlot {
  std::atomic<std::uint32_t> state;  // 0 free, 1 being named, 2 named
  char name[32];
  std::atomic<std::int32_t> owner[2];  // the process id holding each side (0: none)
  ShmRing ring[2];                     // ring[s]: towards side s
};

// All zero is a valid empty segment: a new segment needs no initialisation beyond ftruncate.
struct ShmSegment {
  std::atomic<std::uint32_t> magic;
  std::atomic<std::uint32_t> version;
  alignas(64) std::atomic<std::uint32_t> bell[2];  // bell[s]: rung for side s's reader
  alignas(64) std::atomic<std::uint32_t> spinning[2];  // spinning[s]: side s's reader is looking
  ShmBusSlot slots[kShmMaxBuses];
};

static_assert(std::atomic<std::uint64_t>::is_always_lock_free);
static_assert(std::atomic<std::uint32_t>::is_always_lock_free);
static_assert(std::is_trivially_copyable_v<hal::CanFrame>);

}  // namespace internal

namespace {

using internal::ShmSegment;

int Index(ShmSide s) { return s == ShmSide::kMaster ? 0 : 1; }  // the other side: 1 − Index
const char* SideName(ShmSide s) { return s == ShmSide::kMaster ? "master" : "devices"; }

bool ValidName(const std::string& n, std::size_t max) {
  if (n.empty() || n.size() > max) return false;
  return std::all_of(n.begin(), n.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '.' || c == '-';
  });
}

bool Alive(std::int32_t pid) { return pid > 0 && (::kill(pid, 0) == 0 || errno == EPERM); }

std::int64_t RealtimeNs() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

ShmChannel::ShmChannel(const ShmOptions& options) : options_(options) {
  if (options_.name.empty()) options_.name = "shm:" + options_.group + ":" + options_.bus;
  const auto fail = [&](const std::string& what) {
    throw ChannelError("channel '" + options_.name + "': " + what);
  };
  if (!ValidName(options_.group, 48))
    fail("expected a group of 1..48 letters, digits, '_', '.' or '-', found '" + options_.group + "'");
  if (!ValidName(options_.bus, 31))
    fail("expected a bus name of 1..31 letters, digits, '_', '.' or '-', found '" + options_.bus + "'");
  segment_name_ = "/hyq-can." + options_.group;
  const ShmSide other = options_.side == ShmSide::kMaster ? ShmSide::kDevices : ShmSide::kMaster;
  bell_rx_path_ = "/dev/shm/hyq-can." + options_.group + ".bell-" + SideName(options_.side);
  bell_tx_path_ = "/dev/shm/hyq-can." + options_.group + ".bell-" + SideName(other);

  // the segment: created zero-filled (a valid empty one) by whichever side comes first
  const int fd = ::shm_open(segment_name_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (fd < 0) fail(std::string("shm_open ") + segment_name_ + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    fail(std::string("fstat: ") + std::strerror(errno));
  }
  const auto bytes = static_cast<off_t>(sizeof(ShmSegment));
  if (st.st_size == 0 && ::ftruncate(fd, bytes) != 0) {
    ::close(fd);
    fail(std::string("ftruncate: ") + std::strerror(errno));
  }
  if (st.st_size != 0 && st.st_size != bytes) {
    ::close(fd);
    fail("/dev/shm" + segment_name_ + " has " + std::to_string(st.st_size) + " bytes, expected " +
         std::to_string(bytes) + " (another version's segment: remove it)");
  }
  void* p = ::mmap(nullptr, sizeof(ShmSegment), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  ::close(fd);
  if (p == MAP_FAILED) fail(std::string("mmap: ") + std::strerror(errno));
  segment_ = static_cast<ShmSegment*>(p);
  std::uint32_t magic = 0;
  segment_->magic.compare_exchange_strong(magic, internal::kShmMagic);
  std::uint32_t version = 0;
  segment_->version.compare_exchange_strong(version, internal::kShmVersion);
  if (segment_->magic.load() != internal::kShmMagic || segment_->version.load() != internal::kShmVersion) {
    ::munmap(segment_, sizeof(ShmSegment));
    segment_ = nullptr;
    fail("/dev/shm" + segment_name_ + " is not a version " + std::to_string(internal::kShmVersion) +
         " segment (remove it)");
  }

  // the bus's slot: the one already named so, else the first free one (named by a CAS)
  bool found = false;
  for (std::size_t i = 0; i < kShmMaxBuses && !found; ++i) {
    internal::ShmBusSlot& s = segment_->slots[i];
    std::uint32_t state = 0;
    if (s.state.compare_exchange_strong(state, 1)) {
      std::memset(s.name, 0, sizeof s.name);
      std::memcpy(s.name, options_.bus.data(), options_.bus.size());
      s.state.store(2);
      slot_ = i;
      found = true;
      break;
    }
    for (int spins = 0; s.state.load() == 1 && spins < 1'000'000; ++spins) {
    }
    if (s.state.load() == 2 && std::strncmp(s.name, options_.bus.c_str(), sizeof s.name) == 0) {
      slot_ = i;
      found = true;
    }
  }
  const auto unmap_and_fail = [&](const std::string& what) {
    ::munmap(segment_, sizeof(ShmSegment));
    segment_ = nullptr;
    fail(what);
  };
  if (!found)
    unmap_and_fail("no free bus in /dev/shm" + segment_name_ + " (at most " +
                   std::to_string(kShmMaxBuses) + " buses per group)");

  // this side of the bus: ours unless a live process holds it
  internal::ShmBusSlot& slot = segment_->slots[slot_];
  const std::int32_t me = ::getpid();
  std::atomic<std::int32_t>& owner = slot.owner[Index(options_.side)];
  for (std::int32_t held = owner.load();;) {
    if (held != 0 && Alive(held))  // this process's other channel on the bus too
      unmap_and_fail(std::string("its ") + SideName(options_.side) + " side is held by process " +
                     std::to_string(held));
    if (owner.compare_exchange_strong(held, me)) break;
  }
  // frames a previous holder of this side left unread are not ours
  internal::ShmRing& in = slot.ring[Index(options_.side)];
  in.head.store(in.tail.load());

  // the doorbells: FIFOs beside the segment, opened read-write so that neither open blocks
  for (const std::string* path : {&bell_rx_path_, &bell_tx_path_}) {
    if (::mkfifo(path->c_str(), 0600) != 0 && errno != EEXIST) {
      owner.store(0);
      unmap_and_fail("mkfifo " + *path + ": " + std::strerror(errno));
    }
    struct stat fst {};
    if (::stat(path->c_str(), &fst) != 0 || !S_ISFIFO(fst.st_mode)) {
      owner.store(0);
      unmap_and_fail(*path + " exists and is not a FIFO");
    }
  }
  bell_rx_fd_ = ::open(bell_rx_path_.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  bell_tx_fd_ = ::open(bell_tx_path_.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (bell_rx_fd_ < 0 || bell_tx_fd_ < 0) {
    const int err = errno;
    if (bell_rx_fd_ >= 0) ::close(bell_rx_fd_);
    if (bell_tx_fd_ >= 0) ::close(bell_tx_fd_);
    bell_rx_fd_ = bell_tx_fd_ = -1;
    owner.store(0);
    unmap_and_fail(std::string("opening the doorbells: ") + std::strerror(err));
  }
  // a previous holder that died may have left its bell set without a byte, or its spinning flag
  // set (then no writer would ring): start clear, with our bell rung if frames already wait
  segment_->spinning[Index(options_.side)].store(0);
  TakeBell();
}

ShmChannel::~ShmChannel() {
  if (segment_ != nullptr) {
    std::int32_t me = ::getpid();
    segment_->slots[slot_].owner[Index(options_.side)].compare_exchange_strong(me, 0);
    ::munmap(segment_, sizeof(ShmSegment));
  }
  if (bell_rx_fd_ >= 0) ::close(bell_rx_fd_);
  if (bell_tx_fd_ >= 0) ::close(bell_tx_fd_);
  // the devices' side (the simulator) owns the bus's life: its end removes the names, so that the
  // next simulator starts on a new segment (a master still attached keeps its mapping and sees
  // no more answers)
  if (options_.side == ShmSide::kDevices && segment_ != nullptr) {
    ::shm_unlink(segment_name_.c_str());
    ::unlink(bell_rx_path_.c_str());
    ::unlink(bell_tx_path_.c_str());
  }
}

bool ShmChannel::AllIncomingEmpty() const noexcept {
  const int s = Index(options_.side);
  for (const internal::ShmBusSlot& slot : segment_->slots) {
    if (slot.state.load() != 2) continue;
    if (slot.ring[s].tail.load() != slot.ring[s].head.load()) return false;
  }
  return true;
}

void ShmChannel::TakeBell() noexcept {
  char bytes[64];
  while (::read(bell_rx_fd_, bytes, sizeof bytes) > 0) {
  }
  std::atomic<std::uint32_t>& bell = segment_->bell[Index(options_.side)];
  bell.store(0);  // seq_cst: cleared before the rings are looked at again
  if (!AllIncomingEmpty() && bell.exchange(1) == 0) {
    const char b = 1;
    (void)!::write(bell_rx_fd_, &b, 1);
  }
}

void ShmChannel::SetWaiterSpinning(bool on) noexcept {
  if (segment_ != nullptr) segment_->spinning[Index(options_.side)].store(on ? 1 : 0);  // seq_cst
}

void ShmChannel::Ring() noexcept {
  const int other = 1 - Index(options_.side);
  if (segment_->spinning[other].load() != 0) return;  // it looks again before it sleeps
  if (segment_->bell[other].exchange(1) == 0) {
    const char b = 1;
    if (::write(bell_tx_fd_, &b, 1) == 1) ++bells_rung_;
  }
}

hal::CanStatus ShmChannel::Send(std::span<const hal::CanFrame> frames, std::size_t* sent) noexcept {
  *sent = 0;
  if (segment_ == nullptr) return hal::CanStatus::kClosed;
  const int other = 1 - Index(options_.side);
  internal::ShmRing& out = segment_->slots[slot_].ring[other];
  const std::uint64_t head = out.head.load(std::memory_order_acquire);
  std::uint64_t tail = out.tail.load(std::memory_order_relaxed);
  hal::CanStatus status = hal::CanStatus::kOk;
  for (const hal::CanFrame& f : frames) {
    const bool fd_frame = f.is_fd();
    if ((fd_frame && !options_.fd) || f.len > (fd_frame ? hal::kCanFdMaxData : hal::kCanClassicMaxData)) {
      ++counters_.bad_frames;
      status = hal::CanStatus::kBadFrame;
      break;
    }
    if (tail - head >= kShmRingFrames) {
      counters_.tx_would_block += frames.size() - *sent;
      status = hal::CanStatus::kWouldBlock;
      break;
    }
    out.frames[tail % kShmRingFrames] = f;
    ++tail;
    ++*sent;
  }
  if (*sent > 0) {
    out.tail.store(tail);  // seq_cst: published before the bell is looked at
    counters_.tx_frames += *sent;
    Ring();
  }
  return status;
}

hal::CanStatus ShmChannel::Receive(std::span<hal::CanFrame> out, std::size_t* received) noexcept {
  *received = 0;
  if (segment_ == nullptr) return hal::CanStatus::kClosed;
  const int s = Index(options_.side);
  internal::ShmRing& in = segment_->slots[slot_].ring[s];
  const std::uint64_t tail = in.tail.load(std::memory_order_acquire);
  std::uint64_t head = in.head.load(std::memory_order_relaxed);
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(tail - head, out.size()));
  if (n > 0) {
    const std::int64_t now = RealtimeNs();
    for (std::size_t k = 0; k < n; ++k, ++head) {
      out[k] = in.frames[head % kShmRingFrames];
      out[k].timestamp_ns = now;
    }
    in.head.store(head, std::memory_order_release);
    *received = n;
    counters_.rx_frames += n;
  }
  // drained: take the bell when every bus of the group is empty for our side (the rule in the
  // header: empty the FIFO, clear the bell, look again, ring it back if frames came meanwhile)
  if (n < out.size() && segment_->bell[s].load() != 0 && AllIncomingEmpty()) {
    TakeBell();
    ++bells_taken_;
  }
  return hal::CanStatus::kOk;
}

}  // namespace hyq::drivers
