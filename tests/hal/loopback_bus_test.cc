#include "hal/loopback_bus.h"

#include <gtest/gtest.h>

#include <array>

#include "hal/lockstep_channel.h"
#include "hal/protocol.h"

namespace hyq::hal {
namespace {

TEST(LoopbackBus, EveryOtherEndpointReceivesWhatOneSends) {
  LoopbackBus bus("t", 3, 8);
  const CanFrame f = EncodeSync(9);
  std::size_t sent = 0;
  ASSERT_EQ(bus.endpoint(0).Send({&f, 1}, &sent), CanStatus::kOk);
  EXPECT_EQ(sent, 1u);
  std::array<CanFrame, 4> rx;
  std::size_t n = 0;
  EXPECT_EQ(bus.endpoint(0).Receive(rx, &n), CanStatus::kOk);
  EXPECT_EQ(n, 0u) << "the sender does not hear itself";
  for (std::size_t e : {1u, 2u}) {
    ASSERT_EQ(bus.endpoint(e).Receive(rx, &n), CanStatus::kOk);
    ASSERT_EQ(n, 1u);
    EXPECT_EQ(rx[0].id, 0x080u);
    EXPECT_EQ(rx[0].data[0], 9);
  }
  EXPECT_EQ(bus.endpoint(0).counters().tx_frames, 1u);
  EXPECT_EQ(bus.endpoint(2).counters().rx_frames, 1u);
  EXPECT_EQ(bus.endpoint(1).name(), "t.1");
}

TEST(LoopbackBus, FullQueueCountsOverflowAndKeepsOrder) {
  LoopbackBus bus("t", 2, 4);
  std::array<CanFrame, 6> tx;
  for (std::size_t i = 0; i < tx.size(); ++i) tx[i] = EncodeSync(static_cast<std::uint8_t>(i + 1));
  std::size_t sent = 0;
  ASSERT_EQ(bus.endpoint(0).Send(tx, &sent), CanStatus::kOk);
  EXPECT_EQ(bus.endpoint(1).counters().rx_overflow, 2u);
  std::array<CanFrame, 8> rx;
  std::size_t n = 0;
  ASSERT_EQ(bus.endpoint(1).Receive(rx, &n), CanStatus::kOk);
  ASSERT_EQ(n, 4u);
  for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(rx[i].data[0], i + 1);
}

TEST(LoopbackBus, ClassicBusRefusesFdFramesAndBusOffStopsTraffic) {
  LoopbackBus classic("c", 2, 4, /*fd=*/false);
  const CanFrame fd = EncodeActuatorTpdo(1, {});
  std::size_t sent = 0;
  EXPECT_EQ(classic.endpoint(0).Send({&fd, 1}, &sent), CanStatus::kBadFrame);
  EXPECT_EQ(sent, 0u);
  EXPECT_EQ(classic.endpoint(0).counters().bad_frames, 1u);

  LoopbackBus bus("b", 2, 4);
  bus.SetBusOff(true);
  const CanFrame f = EncodeSync(1);
  EXPECT_EQ(bus.endpoint(0).Send({&f, 1}, &sent), CanStatus::kBusOff);
  EXPECT_EQ(bus.endpoint(0).counters().bus_state, BusState::kBusOff);
  EXPECT_EQ(bus.endpoint(0).counters().bus_off_events, 1u);
  bus.SetBusOff(false);
  EXPECT_EQ(bus.endpoint(0).Send({&f, 1}, &sent), CanStatus::kOk);
  EXPECT_EQ(bus.endpoint(1).pending(), 1u);
}

// A non-owning view of a bus endpoint (LockstepChannel owns what it wraps).
class EndpointView : public CanChannel {
 public:
  explicit EndpointView(CanChannel& c) : c_(c) {}
  CanStatus Send(std::span<const CanFrame> f, std::size_t* n) noexcept override { return c_.Send(f, n); }
  CanStatus Receive(std::span<CanFrame> f, std::size_t* n) noexcept override { return c_.Receive(f, n); }
  const CanCounters& counters() const noexcept override { return c_.counters(); }
  bool fd_enabled() const noexcept override { return c_.fd_enabled(); }
  std::string_view name() const noexcept override { return c_.name(); }

 private:
  CanChannel& c_;
};

// Lock-step waits count answers per device: a TPDO from node 3 says nothing about node 4.
TEST(LockstepChannel, KnowsWhichNodesAnswered) {
  LoopbackBus bus("t", 2, 16, true);
  LockstepChannel ls(std::make_unique<EndpointView>(bus.endpoint(0)));
  const std::array<CanFrame, 3> frames{EncodeActuatorTpdo(3, {}), EncodeSync(1),
                                       EncodeHeartbeat(4, NmtState::kOperational)};
  std::size_t sent = 0;
  ASSERT_EQ(bus.endpoint(1).Send(frames, &sent), CanStatus::kOk);
  EXPECT_EQ(ls.Pump(), 1);
  EXPECT_TRUE(ls.has_tpdo_from(3));
  EXPECT_FALSE(ls.has_tpdo_from(4));  // a heartbeat is not an answer
  std::array<CanFrame, 8> rx;
  std::size_t n = 0;
  EXPECT_EQ(ls.Receive(rx, &n), CanStatus::kOk);
  EXPECT_EQ(n, 3u);  // the HAL gets every frame, in order
  EXPECT_EQ(rx[0].id, frames[0].id);
  EXPECT_FALSE(ls.has_tpdo_from(3));  // taken: the next SYNC starts afresh
}

}  // namespace
// A late answer to an earlier SYNC is not an answer to the one just sent: a lock-step master that
// counted it would run its next cycle without the device's current input.
TEST(LockstepChannel, CountsOnlyAnswersToTheLastSync) {
  LoopbackBus bus("t", 2, 16, true);
  LockstepChannel ls(std::make_unique<EndpointView>(bus.endpoint(0)));
  std::size_t sent = 0;
  const std::array<CanFrame, 1> sync7{EncodeSync(7)};
  ASSERT_EQ(ls.Send(sync7, &sent), CanStatus::kOk);
  ActuatorTpdo late, now;
  late.sync_counter = 6;
  now.sync_counter = 7;
  ImuTpdo imu_late, imu_now;
  imu_late.sync_counter = 6;
  imu_now.sync_counter = 7;
  const std::array<CanFrame, 2> old_answers{EncodeActuatorTpdo(3, late), EncodeImuTpdo(16, imu_late)};
  ASSERT_EQ(bus.endpoint(1).Send(old_answers, &sent), CanStatus::kOk);
  EXPECT_EQ(ls.Pump(), 0);
  EXPECT_FALSE(ls.has_tpdo_from(3));
  EXPECT_FALSE(ls.has_tpdo_from(16));
  const std::array<CanFrame, 2> answers{EncodeActuatorTpdo(3, now), EncodeImuTpdo(16, imu_now)};
  ASSERT_EQ(bus.endpoint(1).Send(answers, &sent), CanStatus::kOk);
  EXPECT_EQ(ls.Pump(), 2);
  EXPECT_TRUE(ls.has_tpdo_from(3));
  EXPECT_TRUE(ls.has_tpdo_from(16));
  // the next SYNC: what is buffered answered the previous one
  const std::array<CanFrame, 1> sync8{EncodeSync(8)};
  ASSERT_EQ(ls.Send(sync8, &sent), CanStatus::kOk);
  EXPECT_EQ(ls.Pump(), 0);
  EXPECT_FALSE(ls.has_tpdo_from(3));
  std::array<CanFrame, 8> rx;
  std::size_t n = 0;
  EXPECT_EQ(ls.Receive(rx, &n), CanStatus::kOk);
  EXPECT_EQ(n, 4u);  // the HAL still gets every frame, late ones included
}

// A simulated plant's clock (hal::PlantClock) is the lock-step clock's: taken out before the HAL
// whether Pump or Receive reads it first, its count kept (the newest: the largest), the frames
// around it passed on in order.
TEST(LockstepChannel, TakesThePlantClockOutOnBothPaths) {
  LoopbackBus bus("t", 2, 16, true);
  LockstepChannel ls(std::make_unique<EndpointView>(bus.endpoint(0)));
  std::size_t sent = 0;
  ActuatorTpdo a;
  a.sync_counter = 1;
  const std::array<CanFrame, 3> pumped{EncodeHeartbeat(3, NmtState::kOperational),
                                       EncodePlantClock({1000, 19}), EncodeActuatorTpdo(3, a)};
  ASSERT_EQ(bus.endpoint(1).Send(pumped, &sent), CanStatus::kOk);
  EXPECT_EQ(ls.Pump(), 1);
  EXPECT_EQ(ls.plant_stalled_steps(), 19u);
  EXPECT_EQ(ls.buffered(), 2u);
  const std::array<CanFrame, 2> direct{EncodePlantClock({1100, 24}), EncodeSync(2)};
  ASSERT_EQ(bus.endpoint(1).Send(direct, &sent), CanStatus::kOk);
  std::array<CanFrame, 8> rx;
  std::size_t n = 0;
  EXPECT_EQ(ls.Receive(rx, &n), CanStatus::kOk);
  ASSERT_EQ(n, 3u);
  EXPECT_EQ(rx[0].id, cob::kHeartbeat + 3);
  EXPECT_EQ(rx[1].id, cob::kTpdo1 + 3);
  EXPECT_EQ(rx[2].id, cob::kSync);
  EXPECT_EQ(ls.plant_stalled_steps(), 24u);
}

}  // namespace hyq::hal
