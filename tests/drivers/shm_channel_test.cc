// The shared-memory virtual CAN (drivers/shm_channel.h): frames both ways in order, the doorbell
// (readable exactly while frames wait, across the buses of a group, no lost wake-up), one holder
// per side, a dead holder's side taken over, a full ring, bad frames, the devices' side removing
// the segment, and the spec.
#include "drivers/shm_channel.h"

#include <poll.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <string>
#include <vector>

#include "drivers/channel_error.h"
#include "drivers/channel_factory.h"
#include "hal/clock.h"
#include "hal/lockstep_channel.h"

namespace hyq::drivers {
namespace {

// a group name of this test process's own, so that parallel tests never share a segment
std::string Group(const char* what) { return std::string("test-") + what + "-" + std::to_string(::getpid()); }

ShmOptions Opts(const std::string& group, const std::string& bus, ShmSide side) {
  ShmOptions o;
  o.group = group;
  o.bus = bus;
  o.side = side;
  return o;
}

bool Readable(int fd) {
  pollfd p{fd, POLLIN, 0};
  return ::poll(&p, 1, 0) == 1 && (p.revents & POLLIN) != 0;
}

hal::CanFrame Frame(std::uint32_t id, std::uint8_t len, bool fd = false) {
  hal::CanFrame f;
  f.id = id;
  f.len = len;
  if (fd) f.flags = hal::CanFrame::kFd;
  for (std::uint8_t k = 0; k < len; ++k) f.data[k] = static_cast<std::uint8_t>(id + k);
  return f;
}

// a child process opens bus lf's master side (spinning when asked) and exits without closing it
bool MasterDiesHoldingTheSide(const std::string& group, bool spinning) {
  const pid_t child = ::fork();
  if (child == 0) {
    auto* m = new ShmChannel(Opts(group, "lf", ShmSide::kMaster));
    m->SetWaiterSpinning(spinning);
    ::_exit(0);
  }
  int status = 0;
  return ::waitpid(child, &status, 0) == child && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

TEST(ShmChannel, FramesCrossBothWaysInOrder) {
  const std::string g = Group("order");
  ShmChannel devices(Opts(g, "lf", ShmSide::kDevices));
  ShmChannel master(Opts(g, "lf", ShmSide::kMaster));
  const std::vector<hal::CanFrame> out{Frame(0x80, 0), Frame(0x201, 8), Frame(0x301, 64, true)};
  std::size_t sent = 0;
  ASSERT_EQ(master.Send(out, &sent), hal::CanStatus::kOk);
  EXPECT_EQ(sent, 3u);
  std::array<hal::CanFrame, 8> in{};
  std::size_t got = 0;
  ASSERT_EQ(devices.Receive(in, &got), hal::CanStatus::kOk);
  ASSERT_EQ(got, 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(in[k].id, out[k].id);
    EXPECT_EQ(in[k].len, out[k].len);
    EXPECT_EQ(in[k].flags, out[k].flags);
    EXPECT_EQ(in[k].data, out[k].data);
    EXPECT_GT(in[k].timestamp_ns, 0);
  }
  // the master hears nothing of its own frames; the answer comes back
  ASSERT_EQ(master.Receive(in, &got), hal::CanStatus::kOk);
  EXPECT_EQ(got, 0u);
  ASSERT_EQ(devices.Send(std::span(out).first(1), &sent), hal::CanStatus::kOk);
  ASSERT_EQ(master.Receive(in, &got), hal::CanStatus::kOk);
  EXPECT_EQ(got, 1u);
  EXPECT_EQ(master.counters().tx_frames, 3u);
  EXPECT_EQ(master.counters().rx_frames, 1u);
}

TEST(ShmChannel, TheDoorbellIsReadableExactlyWhileFramesWait) {
  const std::string g = Group("bell");
  ShmChannel devices(Opts(g, "lf", ShmSide::kDevices));
  ShmChannel master(Opts(g, "lf", ShmSide::kMaster));
  EXPECT_FALSE(Readable(devices.poll_fd()));
  const std::array<hal::CanFrame, 1> f{Frame(0x80, 0)};
  std::size_t sent = 0, got = 0;
  for (int round = 0; round < 3; ++round) {
    ASSERT_EQ(master.Send(f, &sent), hal::CanStatus::kOk);
    ASSERT_EQ(master.Send(f, &sent), hal::CanStatus::kOk);  // the bell is rung once
    EXPECT_TRUE(Readable(devices.poll_fd()));
    std::array<hal::CanFrame, 8> in{};
    ASSERT_EQ(devices.Receive(in, &got), hal::CanStatus::kOk);
    EXPECT_EQ(got, 2u);
    EXPECT_FALSE(Readable(devices.poll_fd())) << "round " << round;
  }
  EXPECT_EQ(master.bells_rung(), 3u);
  EXPECT_EQ(devices.bells_taken(), 3u);
}

TEST(ShmChannel, OneBellForTheGroupWithoutALostWakeUp) {
  const std::string g = Group("group");
  ShmChannel dev_lf(Opts(g, "lf", ShmSide::kDevices)), dev_rf(Opts(g, "rf", ShmSide::kDevices));
  ShmChannel m_lf(Opts(g, "lf", ShmSide::kMaster)), m_rf(Opts(g, "rf", ShmSide::kMaster));
  EXPECT_EQ(dev_lf.poll_fd() >= 0, true);
  const std::array<hal::CanFrame, 1> f{Frame(0x80, 0)};
  std::size_t sent = 0, got = 0;
  std::array<hal::CanFrame, 8> in{};
  ASSERT_EQ(m_lf.Send(f, &sent), hal::CanStatus::kOk);
  ASSERT_EQ(m_rf.Send(f, &sent), hal::CanStatus::kOk);
  EXPECT_EQ(m_lf.bells_rung() + m_rf.bells_rung(), 1u);  // one byte for both buses
  // lf drained, rf still waiting: the bell stays rung
  ASSERT_EQ(dev_lf.Receive(in, &got), hal::CanStatus::kOk);
  EXPECT_EQ(got, 1u);
  EXPECT_TRUE(Readable(dev_lf.poll_fd()));
  // lf drained again while rf waits: still rung
  ASSERT_EQ(dev_lf.Receive(in, &got), hal::CanStatus::kOk);
  EXPECT_TRUE(Readable(dev_rf.poll_fd()));
  ASSERT_EQ(dev_rf.Receive(in, &got), hal::CanStatus::kOk);
  EXPECT_EQ(got, 1u);
  EXPECT_FALSE(Readable(dev_rf.poll_fd()));
  // a frame after the bell was taken rings it again
  ASSERT_EQ(m_rf.Send(f, &sent), hal::CanStatus::kOk);
  EXPECT_TRUE(Readable(dev_lf.poll_fd()));
}

TEST(ShmChannel, ASpinningReaderIsNotRungAndSeesTheFramesWhenItStops) {
  const std::string g = Group("spin");
  ShmChannel devices(Opts(g, "lf", ShmSide::kDevices));
  ShmChannel master(Opts(g, "lf", ShmSide::kMaster));
  EXPECT_TRUE(devices.tells_pending());
  EXPECT_FALSE(devices.frames_pending());
  const std::array<hal::CanFrame, 1> f{Frame(0x80, 0)};
  std::size_t sent = 0, got = 0;
  devices.SetWaiterSpinning(true);
  ASSERT_EQ(master.Send(f, &sent), hal::CanStatus::kOk);
  EXPECT_EQ(master.bells_rung(), 0u);  // no system call for a reader that is looking
  EXPECT_FALSE(Readable(devices.poll_fd()));
  devices.SetWaiterSpinning(false);
  EXPECT_TRUE(devices.frames_pending());  // the look after the spin finds them
  std::array<hal::CanFrame, 8> in{};
  ASSERT_EQ(devices.Receive(in, &got), hal::CanStatus::kOk);
  EXPECT_EQ(got, 1u);
  EXPECT_EQ(devices.bells_taken(), 0u);
  // not spinning: rung as before
  ASSERT_EQ(master.Send(f, &sent), hal::CanStatus::kOk);
  EXPECT_EQ(master.bells_rung(), 1u);
  EXPECT_TRUE(Readable(devices.poll_fd()));
}

TEST(ShmChannel, SpinForFramesReturnsWhenFramesComeAndAfterItsBudget) {
  const std::string g = Group("spinfor");
  ShmChannel devices(Opts(g, "lf", ShmSide::kDevices));
  ShmChannel master(Opts(g, "lf", ShmSide::kMaster));
  hal::CanChannel* const chans[] = {&devices};
  const std::int64_t t0 = MonotonicNs();
  EXPECT_FALSE(hal::SpinForFrames(chans, 2'000'000));
  EXPECT_GE(MonotonicNs() - t0, 2'000'000);
  const std::array<hal::CanFrame, 1> f{Frame(0x80, 0)};
  std::size_t sent = 0;
  ASSERT_EQ(master.Send(f, &sent), hal::CanStatus::kOk);
  EXPECT_TRUE(hal::SpinForFrames(chans, 1'000'000'000));
}

TEST(ShmChannel, ASideHasOneHolderAndADeadHoldersSideIsTakenOver) {
  const std::string g = Group("owner");
  ShmChannel devices(Opts(g, "lf", ShmSide::kDevices));
  {
    ShmChannel master(Opts(g, "lf", ShmSide::kMaster));
    try {
      ShmChannel again(Opts(g, "lf", ShmSide::kMaster));
      FAIL() << "a second master side was opened";
    } catch (const ChannelError& e) {
      EXPECT_NE(std::string(e.what()).find("master side is held by process " + std::to_string(::getpid())),
                std::string::npos)
          << e.what();
    }
  }
  // a master that died holding the side (no destructor) and left a frame unread
  ASSERT_TRUE(MasterDiesHoldingTheSide(g, false));
  std::size_t sent = 0, got = 0;
  const std::array<hal::CanFrame, 1> f{Frame(0x181, 8)};
  ASSERT_EQ(devices.Send(f, &sent), hal::CanStatus::kOk);
  ShmChannel master(Opts(g, "lf", ShmSide::kMaster));
  std::array<hal::CanFrame, 8> in{};
  ASSERT_EQ(master.Receive(in, &got), hal::CanStatus::kOk);
  EXPECT_EQ(got, 0u) << "the frames left for the dead holder are not the new one's";
}

// a holder that died spinning (writers do not ring a spinning reader) leaves nothing that keeps
// the next one from being woken
TEST(ShmChannel, ANewHolderIsWokenAfterOneThatDiedSpinning) {
  const std::string g = Group("deadspin");
  ShmChannel devices(Opts(g, "lf", ShmSide::kDevices));
  ASSERT_TRUE(MasterDiesHoldingTheSide(g, true));
  ShmChannel master(Opts(g, "lf", ShmSide::kMaster));
  const std::array<hal::CanFrame, 1> f{Frame(0x181, 8)};
  std::size_t sent = 0;
  ASSERT_EQ(devices.Send(f, &sent), hal::CanStatus::kOk);
  EXPECT_TRUE(Readable(master.poll_fd()));
}

TEST(ShmChannel, AFullRingRefusesWithoutLosingWhatWasQueued) {
  const std::string g = Group("full");
  ShmChannel devices(Opts(g, "lf", ShmSide::kDevices));
  ShmChannel master(Opts(g, "lf", ShmSide::kMaster));
  std::vector<hal::CanFrame> many(kShmRingFrames + 10);
  for (std::size_t k = 0; k < many.size(); ++k) many[k] = Frame(static_cast<std::uint32_t>(k), 1);
  std::size_t sent = 0, got = 0;
  EXPECT_EQ(master.Send(many, &sent), hal::CanStatus::kWouldBlock);
  EXPECT_EQ(sent, kShmRingFrames);
  EXPECT_EQ(master.counters().tx_would_block, 10u);
  std::vector<hal::CanFrame> in(kShmRingFrames + 10);
  ASSERT_EQ(devices.Receive(in, &got), hal::CanStatus::kOk);
  ASSERT_EQ(got, kShmRingFrames);
  EXPECT_EQ(in.front().id, 0u);
  EXPECT_EQ(in[got - 1].id, kShmRingFrames - 1);
}

TEST(ShmChannel, BadFramesAreRefused) {
  const std::string g = Group("bad");
  ShmOptions o = Opts(g, "lf", ShmSide::kMaster);
  o.fd = false;
  ShmChannel master(o);
  std::size_t sent = 0;
  const std::array<hal::CanFrame, 1> fd{Frame(0x201, 12, true)};
  EXPECT_EQ(master.Send(fd, &sent), hal::CanStatus::kBadFrame);
  EXPECT_EQ(sent, 0u);
  hal::CanFrame too_long = Frame(0x201, 8);
  too_long.len = 9;
  EXPECT_EQ(master.Send(std::span(&too_long, 1), &sent), hal::CanStatus::kBadFrame);
  EXPECT_EQ(master.counters().bad_frames, 2u);
}

TEST(ShmChannel, TheDevicesSideRemovesTheSegmentWhenItCloses) {
  const std::string g = Group("unlink");
  const std::string path = "/dev/shm/hyq-can." + g;
  struct stat st {};
  {
    ShmChannel devices(Opts(g, "lf", ShmSide::kDevices));
    EXPECT_EQ(::stat(path.c_str(), &st), 0);
    EXPECT_EQ(::stat((path + ".bell-devices").c_str(), &st), 0);
    ShmChannel master(Opts(g, "lf", ShmSide::kMaster));
  }
  EXPECT_NE(::stat(path.c_str(), &st), 0);
  EXPECT_NE(::stat((path + ".bell-master").c_str(), &st), 0);
}

TEST(ShmChannel, TheSpecNamesGroupBusAndSide) {
  const ChannelSpec spec = ParseChannelSpec("shm:hil-1:lf,side=devices,fd=0");
  const auto* o = std::get_if<ShmOptions>(&spec);
  ASSERT_NE(o, nullptr);
  EXPECT_EQ(o->group, "hil-1");
  EXPECT_EQ(o->bus, "lf");
  EXPECT_EQ(o->side, ShmSide::kDevices);
  EXPECT_FALSE(o->fd);
  EXPECT_EQ(ChannelIdentity(ParseChannelSpec("shm:g:rf")), "shm:g:rf");
  EXPECT_EQ(SpecForInterface("shm:g:rf"), "shm:g:rf");
  for (const char* bad : {"shm", "shm:g", "shm:g:", "shm::lf", "shm:g:lf,side=both", "shm:g:lf,ttl=1"})
    EXPECT_THROW((void)ParseChannelSpec(bad), ChannelError) << bad;
  EXPECT_THROW(ShmChannel(Opts("a/b", "lf", ShmSide::kMaster)), ChannelError);
  EXPECT_THROW(ShmChannel(Opts("g", std::string(40, 'x'), ShmSide::kMaster)), ChannelError);
}

}  // namespace
}  // namespace hyq::drivers
