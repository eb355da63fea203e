// The simulated HyQ on UDP-multicast virtual CAN buses (run in a private network namespace):
// in-process (robot thread + HAL master) and the hyq-sim binary against an in-test HAL master.
#include <spawn.h>
#include <sys/wait.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/hil/hil_rig.h"

extern char** environ;

namespace hyq::testing {
namespace {

#define HYQ_REQUIRE_NETNS()                                                                   \
  do {                                                                                        \
    if (std::getenv("HYQ_NETNS") == nullptr)                                                  \
      GTEST_SKIP() << "needs a private network namespace with multicast on lo "               \
                      "(tests/drivers/in_netns.sh; unshare -n not permitted here)";           \
  } while (false)

std::vector<std::string> Specs(int first_port) {
  std::vector<std::string> s;
  for (int b = 0; b < 4; ++b) s.push_back("udp::" + std::to_string(first_port + b));
  return s;
}

auto Pd() {
  return [](hal::ProcessImage& im) { StandingPd(HilModel(), im); };
}

TEST(SimulatedRobotUdp, LockStepBringUpAndStandingOverVirtualBuses) {
  HYQ_REQUIRE_NETNS();
  const hal::HalConfig cfg = HilHalConfig();
  std::vector<std::unique_ptr<hal::CanChannel>> dev;
  std::vector<hal::CanChannel*> d;
  for (const std::string& s : Specs(43101)) {
    dev.push_back(drivers::OpenChannel(s));
    d.push_back(dev.back().get());
  }
  sim::SimulatedRobot robot(HilModel(), cfg, d, {});
  UdpMaster master(Specs(43101));
  std::atomic<bool> stop{false};
  std::thread sim_thread([&] { (void)robot.RunLockStep(stop, 0.0); });
  // stopped and joined on every way out (a failed ASSERT returns: a joinable thread terminates)
  struct Joiner {
    std::atomic<bool>& stop;
    std::thread& thread;
    ~Joiner() {
      stop = true;
      if (thread.joinable()) thread.join();
    }
  } joiner{stop, sim_thread};
  // a guard, not a window: the devices announce themselves as soon as the simulator runs
  ASSERT_TRUE(master.WaitForDevices(60000));
  master.BringUp();
  int not_ok = 0;
  for (int i = 0; i < 500; ++i) not_ok += master.Cycle(Pd()) != hal::HalStatus::kOk;
  stop = true;
  sim_thread.join();
  EXPECT_TRUE(master.hal->AllIn(hal::DeviceState::kOp)) << master.hal->BringUpReport(master.now());
  EXPECT_EQ(not_ok, 0) << "every input arrived every cycle in lock-step";
  EXPECT_FALSE(robot.holding());
  EXPECT_FALSE(robot.fell());
  EXPECT_EQ(robot.counters().lockstep_forced, 0u);
  for (int b = 0; b < 4; ++b) EXPECT_EQ(robot.counters().syncs[b], robot.counters().steps);
  // one step per SYNC the master sent (its cycle count misses the bring-up's last Write)
  EXPECT_NEAR(static_cast<double>(robot.counters().steps), static_cast<double>(master.cycles), 1.0);
  EXPECT_GT(robot.counters().steps, 500u);
}

TEST(HyqSimTool, LockStepAgainstAHalMasterWritesItsSummary) {
  HYQ_REQUIRE_NETNS();
  const std::string dir = ::testing::TempDir();
  const std::string summary = dir + "/hyq_sim_summary.json", truth = dir + "/hyq_sim_truth.csv";
  std::vector<std::string> args = {HYQ_SIM_TOOL, "--duration", "0.5", "--start-height", "0",
                                   "--summary", summary,
                                   "--truth", truth, "--truth-every", "50", "--quiet",
                                   "--fault", "0.4:drop:lf_haa:2"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  UdpMaster master(Specs(43101));  // hyq-sim's default buses
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, HYQ_SIM_TOOL, nullptr, nullptr, argv.data(), environ), 0);
  ASSERT_TRUE(master.WaitForDevices(60000)) << "hyq-sim did not announce its devices";
  master.BringUp();
  int status = 0;
  bool exited = false;
  for (int i = 0; i < 5000 && !exited; ++i) {
    (void)master.Cycle(Pd());
    exited = waitpid(pid, &status, WNOHANG) == pid;
  }
  if (!exited) {
    kill(pid, SIGTERM);
    waitpid(pid, &status, 0);
  }
  ASSERT_TRUE(exited) << "hyq-sim did not stop after --duration";
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  std::ifstream in(summary);
  ASSERT_TRUE(in) << summary;
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["mode"], "lockstep");
  EXPECT_NEAR(j["simulated_time_s"].get<double>(), 0.5, 1e-9);
  EXPECT_EQ(j["steps"].get<int>(), 500);
  EXPECT_GT(j["held_steps"].get<int>(), 0);
  EXPECT_FALSE(j["fell"].get<bool>());
  EXPECT_GT(j["min_base_height_m"].get<double>(), 0.4);
  for (const char* b : {"lf", "rf", "lh", "rh"}) EXPECT_GE(j["syncs_per_bus"][b].get<int>(), 500) << b;
  EXPECT_GT(j["speed"].get<double>(), 0.0);
  EXPECT_EQ(j["faults_injected"].get<int>(), 1);
  std::printf("hyq-sim lock-step speed against this master: %.2fx real time overall (bring-up "
              "included), %.2fx after the release at %.3f s\n",
              j["speed"].get<double>(), j["speed_after_release"].get<double>(),
              j["released_at_s"].get<double>());
  std::ifstream t(truth);
  std::string line;
  int rows = 0;
  while (std::getline(t, line)) ++rows;
  EXPECT_EQ(rows, 1 + 10);  // header + every 50th of 500 steps
  EXPECT_GE(master.hal->bus(0).counters().missing, 2u);
}

}  // namespace
}  // namespace hyq::testing
