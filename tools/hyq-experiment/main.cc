// hyq-experiment: the paper's simulated experiments (section 3) on the MuJoCo HyQ with the
// controllers the daemon runs; CSV time series, a results table (Markdown and JSON) beside the
// paper's numbers, and (tools/hyq-experiment/plot.py) the figures. docs/experiments.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/hal_config_loader.h"
#include "config/servo_config_loader.h"
#include "dynamics/urdf_loader.h"
#include "servo/control/id_record.h"
#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"
#include "tools/experiment/experiment.h"
#include "tools/plant_flags/plant_profile_flags.h"

namespace {

using namespace hyq;
using servo::ControllerKind;

constexpr std::string_view kUsage =
    "usage: hyq-experiment [--all | --scenario NAME]... [--out DIR] [--list] [--help]\n"
    "\n"
    "Runs the paper's simulated experiments on the MuJoCo HyQ: trot and one Figure-Eight cycle on\n"
    "mu = 0.1 and 1.0 with PID, PD + gravity compensation, no-slip ID and the two-stage ID (each\n"
    "with its tuned gains; see --gains), Stage I only vs Stage I + II through contact changes\n"
    "(Fig. 1), and 60 s of trotting for the solve times.\n"
    "Writes DIR/<scenario>.csv, DIR/results.json, DIR/results.md and the figures DIR/fig*.png\n"
    "(default DIR: experiments; figures through tools/hyq-experiment/plot.py and matplotlib).\n"
    "\n"
    "  --all            every scenario (about two minutes)\n"
    "  --patch          the icy-patch scenarios only: a trot from mu = 1 across an icy patch\n"
    "                   (mu = 0.1, x in [0.6, 1.2] m) and off it, the controller's mu assumed\n"
    "                   (1.0), given by an oracle, or estimated online; seeds 1-3\n"
    "  --scenario NAME  one scenario (repeatable); --list shows the names\n"
    "  --out DIR        output folder\n"
    "  --record-id      also write every cycle's ID problem, DIR/<scenario>.id.jsonl (hyq-id\n"
    "                   replays them)\n"
    "  --profile NAME   the plant every scenario runs on: ideal (default: the model, torques\n"
    "                   applied as computed) or realistic (model error, HyQ's hydraulics and\n"
    "                   torque loop, joint friction, 1-cycle delay, load-cell bias;\n"
    "                   docs/simulation.md)\n"
    "  --payload KG,X,Y,Z|off, --link-errors SEED|off, --hydraulics on|off,\n"
    "  --joint-friction on|off, --delay-cycles K, --load-cell-bias NM, --bias-seed N\n"
    "                   one factor of the profile changed (after --profile, whatever the\n"
    "                   order; as in hyq-sim --help)\n"
    "  --gains G        the controllers' feedback gains: tuned (default: the shipped ones in\n"
    "                   config/hyq_servo_sim.yaml, each controller its own, from\n"
    "                   scripts/tune_gains.py; docs/baselines.md), untuned (one PD for all,\n"
    "                   300 N m/rad and 8 N m s/rad, no integral: the first wave's rule), or a\n"
    "                   servo configuration FILE whose controller.gains are used\n"
    "  --disturbance-observer\n"
    "                   every scenario's controller with the trunk's disturbance observer in its\n"
    "                   model (controller.disturbance_observer; docs/baselines.md)\n";

struct Scenario {
  std::string name;
  experiment::ExperimentConfig cfg;
};

sim::GroundPatch PatchOfIce() {
  sim::GroundPatch p;
  p.x0_m = 0.6;
  p.x1_m = 1.2;
  p.y0_m = -2.0;
  p.y1_m = 2.0;
  p.mu = 0.1;
  return p;
}

std::vector<Scenario> Scenarios() {
  std::vector<Scenario> all;
  const std::pair<const char*, ControllerKind> controllers[] = {
      {"pid", ControllerKind::kPid}, {"noslip", ControllerKind::kNoSlipId},
      {"two_stage", ControllerKind::kTwoStageId}, {"pd_gravity", ControllerKind::kPdGravity}};
  for (double mu : {0.1, 1.0}) {
    for (auto [cname, kind] : controllers) {
      char buf[64];
      std::snprintf(buf, sizeof(buf), "trot_mu%.1f_%s", mu, cname);
      experiment::ExperimentConfig c;
      c.reference = servo::Reference::Kind::kTrot;
      c.duration_s = 6.0;
      c.mu = mu;
      c.controller = experiment::StandardController(kind);
      all.push_back({buf, c});
      std::snprintf(buf, sizeof(buf), "eight_mu%.1f_%s", mu, cname);
      c.reference = servo::Reference::Kind::kFigureEight;
      c.duration_s = c.figure_eight.start_delay_s + c.figure_eight.period_s + 0.5;
      all.push_back({buf, c});
    }
  }
  for (auto [cname, kind] : {std::pair{"stage1", ControllerKind::kStage1Id},
                             std::pair{"two_stage", ControllerKind::kTwoStageId}}) {
    experiment::ExperimentConfig c;
    c.reference = servo::Reference::Kind::kTrot;
    c.duration_s = 3.0;
    c.mu = 1.0;
    c.controller = experiment::StandardController(kind);
    all.push_back({std::string("fig1_") + cname, c});
  }
  // trot from μ = 1 across an icy patch and off it again (front feet on it from about
  // 2.4 s, hind feet off it at about 9 s)
  for (auto [sname, source] : {std::pair{"assumed", experiment::MuSource::kAssumed},
                               std::pair{"oracle", experiment::MuSource::kOracle},
                               std::pair{"estimated", experiment::MuSource::kEstimated}}) {
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      experiment::ExperimentConfig c;
      c.reference = servo::Reference::Kind::kTrot;
      c.duration_s = 10.0;
      c.mu = 1.0;
      c.patches = {PatchOfIce()};
      c.mu_source = source;
      c.controller = experiment::StandardController(ControllerKind::kTwoStageId);
      c.seed = seed;
      c.initial_perturbation_rad = 0.02;
      all.push_back({std::string("patch_") + sname + "_s" + std::to_string(seed), c});
    }
  }
  experiment::ExperimentConfig t;
  t.reference = servo::Reference::Kind::kTrot;
  t.duration_s = 60.0;
  t.mu = 0.1;
  t.controller = experiment::StandardController(ControllerKind::kTwoStageId);
  all.push_back({"timing_trot60_two_stage", t});
  for (auto& s : all) s.cfg.name = s.name;
  return all;
}

// The icy patch's table: per μ source, mean and spread over the seeds on the patch, and the
// estimate's settling after each change of the ground under a foot.
void WritePatchTable(const nlohmann::json& results, std::ostream& md) {
  struct Acc {
    std::vector<double> err, slip, all_err;
    int falls = 0, runs = 0;
    std::vector<int> down_footfalls, up_footfalls;  // onto the ice, off it
    std::vector<double> down_lag, up_lag;
    int unsettled = 0;
  };
  std::map<std::string, Acc> by;
  for (const auto& [name, r] : results.items()) {
    if (!r.contains("patch")) continue;
    Acc& a = by[r["patch"]["mu_source"].get<std::string>()];
    ++a.runs;
    a.falls += r["fell"].get<bool>() ? 1 : 0;
    a.err.push_back(r["patch"]["mean_error_rad"].get<double>());
    a.slip.push_back(r["patch"]["mean_slip_speed_m_s"].get<double>());
    a.all_err.push_back(r["mean_error_rad"].get<double>());
    for (const auto& st : r["patch"]["settling"]) {
      const bool down = st["to_mu"].get<double>() < st["from_mu"].get<double>();
      const int n = st["footfalls"].get<int>();
      if (n < 0) {
        ++a.unsettled;
        continue;
      }
      (down ? a.down_footfalls : a.up_footfalls).push_back(n);
      (down ? a.down_lag : a.up_lag).push_back(st["lag_s"].get<double>());
    }
  }
  if (by.empty()) return;
  auto stats = [](const std::vector<double>& v) {
    double mean = 0, lo = v.empty() ? 0 : v[0], hi = lo;
    for (double x : v) {
      mean += x;
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    char b[64];
    std::snprintf(b, sizeof(b), "%.4f (%.4f–%.4f)", v.empty() ? 0.0 : mean / static_cast<double>(v.size()), lo, hi);
    return std::string(b);
  };
  auto worst = [](const auto& v) {
    return v.empty() ? std::string("–") : std::to_string(*std::max_element(v.begin(), v.end()));
  };
  auto worst_s = [](const std::vector<double>& v) {
    if (v.empty()) return std::string("–");
    char b[32];
    std::snprintf(b, sizeof(b), "%.2f", *std::max_element(v.begin(), v.end()));
    return std::string(b);
  };
  md << "\nThe icy patch: trot from μ = 1 across an icy patch (μ = 0.1) and off it; mean (min–max) over "
        "the seeds; on the patch = cycles with a stance foot on it\n\n"
        "| controller's μ | runs | falls | mean error on the patch (rad) | mean stance-foot slip on "
        "the patch (m/s) | mean error, whole run (rad) | footfalls to settle onto / off the ice "
        "(worst) | settling time onto / off the ice, worst (s) | changes never settled |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
  for (const char* src : {"assumed", "oracle", "estimated"}) {
    if (!by.count(src)) continue;
    const Acc& a = by[src];
    const bool est = std::string(src) == "estimated";
    md << "| " << src << " | " << a.runs << " | " << a.falls << " | " << stats(a.err) << " | "
       << stats(a.slip) << " | " << stats(a.all_err) << " | "
       << (est ? worst(a.down_footfalls) + " / " + worst(a.up_footfalls) : std::string("–"))
       << " | " << (est ? worst_s(a.down_lag) + " / " + worst_s(a.up_lag) : std::string("–"))
       << " | " << (est ? std::to_string(a.unsettled) : std::string("–")) << " |\n";
  }
}

// The paper's comparisons, ours beside them (docs/experiments.md explains the differences).
void WriteTables(nlohmann::json& results, const std::string& out_dir) {
  auto err = [&](const std::string& n) -> double {
    return results.contains(n) ? results[n]["mean_error_rad"].get<double>() : std::nan("");
  };
  auto fell = [&](const std::string& n) { return results.contains(n) && results[n]["fell"].get<bool>(); };
  auto change = [&](const std::string& a, const std::string& b) { return 100.0 * (err(a) - err(b)) / err(b); };
  nlohmann::json cmp = nlohmann::json::array();
  auto row = [&](const std::string& what, double ours, const std::string& paper, bool valid) {
    cmp.push_back({{"comparison", what}, {"ours_percent", valid ? nlohmann::json(ours) : nlohmann::json()},
                   {"paper", paper}});
  };
  row("trot, mu = 0.1: two-stage ID vs PID, mean position error", change("trot_mu0.1_two_stage", "trot_mu0.1_pid"),
      "-77.08 %", results.contains("trot_mu0.1_pid") && results.contains("trot_mu0.1_two_stage"));
  row("Figure-Eight, mu = 0.1: two-stage ID vs PID", change("eight_mu0.1_two_stage", "eight_mu0.1_pid"),
      "-90.33 %", results.contains("eight_mu0.1_pid") && results.contains("eight_mu0.1_two_stage"));
  row("Figure-Eight, mu = 0.1: two-stage ID vs no-slip ID", change("eight_mu0.1_two_stage", "eight_mu0.1_noslip"),
      "-56.30 %", results.contains("eight_mu0.1_noslip") && results.contains("eight_mu0.1_two_stage"));
  row("trot, mu = 0.1: two-stage ID vs PD + gravity compensation",
      change("trot_mu0.1_two_stage", "trot_mu0.1_pd_gravity"), "(not in the paper)",
      results.contains("trot_mu0.1_pd_gravity") && results.contains("trot_mu0.1_two_stage"));
  row("Figure-Eight, mu = 0.1: two-stage ID vs PD + gravity compensation",
      change("eight_mu0.1_two_stage", "eight_mu0.1_pd_gravity"), "(not in the paper)",
      results.contains("eight_mu0.1_pd_gravity") && results.contains("eight_mu0.1_two_stage"));
  row("trot, mu = 1.0: two-stage ID vs no-slip ID", change("trot_mu1.0_two_stage", "trot_mu1.0_noslip"),
      "nearly identical", results.contains("trot_mu1.0_noslip") && results.contains("trot_mu1.0_two_stage"));
  row("Figure-Eight, mu = 1.0: two-stage ID vs no-slip ID", change("eight_mu1.0_two_stage", "eight_mu1.0_noslip"),
      "nearly identical", results.contains("eight_mu1.0_noslip") && results.contains("eight_mu1.0_two_stage"));
  nlohmann::json doc = {{"scenarios", results}, {"comparisons", cmp}};
  if (results.contains("fig1_stage1") && results.contains("fig1_two_stage"))
    doc["chatter_total_variation_Nm"] = {{"stage1", results["fig1_stage1"]["torque_total_variation_Nm"]},
                                         {"two_stage", results["fig1_two_stage"]["torque_total_variation_Nm"]}};
  if (results.contains("timing_trot60_two_stage"))
    doc["timing_us"] = {{"ours", results["timing_trot60_two_stage"]["qp_us"]},
                        {"paper", {{"mean", 1000.0}, {"worst", 36000.0}}}};
  std::ofstream(out_dir + "/results.json") << doc.dump(2) << "\n";

  std::ofstream md(out_dir + "/results.md");
  md << "| scenario | mean error (rad) | max error (rad) | mean stance-foot slip (m/s) | fell |\n"
        "|---|---|---|---|---|\n";
  for (auto& [name, r] : results.items()) {
    char line[256];
    std::snprintf(line, sizeof(line), "| %s | %.4f | %.4f | %.4f | %s |\n", name.c_str(),
                  r["mean_error_rad"].get<double>(), r["max_error_rad"].get<double>(),
                  r["mean_slip_speed_m_s"].get<double>(), r["fell"].get<bool>() ? "yes" : "no");
    md << line;
  }
  md << "\n| comparison | ours | paper |\n|---|---|---|\n";
  for (const auto& c : cmp) {
    char line[256];
    if (c["ours_percent"].is_null())
      std::snprintf(line, sizeof(line), "| %s | (not run) | %s |\n", c["comparison"].get<std::string>().c_str(),
                    c["paper"].get<std::string>().c_str());
    else
      std::snprintf(line, sizeof(line), "| %s | %+.2f %% | %s |\n", c["comparison"].get<std::string>().c_str(),
                    c["ours_percent"].get<double>(), c["paper"].get<std::string>().c_str());
    md << line;
  }
  if (doc.contains("chatter_total_variation_Nm"))
    md << "\nFig. 1 chatter (total variation of the joint torques over the run): Stage I "
       << doc["chatter_total_variation_Nm"]["stage1"].get<double>() << " N m, Stage I + II "
       << doc["chatter_total_variation_Nm"]["two_stage"].get<double>() << " N m\n";
  if (doc.contains("timing_us")) {
    const auto& t = doc["timing_us"]["ours"];
    md << "\nTwo-stage optimisation per cycle over 60 s of trotting: mean " << t["mean"].get<double>()
       << " us, median " << t["median"].get<double>() << " us, 99.9th percentile "
       << t["p999"].get<double>() << " us, worst " << t["max"].get<double>()
       << " us (paper: mean 1 ms, worst 36 ms)\n";
  }
  (void)fell;
  WritePatchTable(results, md);
}

// The command line: what to run, where, on which plant, with which gains.
struct Options {
  bool list = false;  // --list: the scenarios' names, nothing run
  std::vector<const Scenario*> run;
  std::string out_dir = "experiments";
  bool record_id = false;
  sim::PlantProfile profile;
  std::string gains_source = "tuned";
  std::optional<servo::ControllerConfig> gains;  // none: untuned
  bool disturbance_observer = false;
};

Options Parse(cli::CommandLine& cl, const std::vector<Scenario>& scenarios) {
  Options o;
  bool all = false;
  std::vector<std::string> wanted;
  cli::PlantProfileFlags plant(/*sensors=*/false);
  while (cl.Next()) {
    if (plant.Read(cl)) continue;
    if (cl.Flag("--list")) o.list = true;
    else if (cl.Flag("--all")) all = true;
    else if (cl.Flag("--patch")) {
      for (const auto& s : scenarios)
        if (s.name.starts_with("patch_")) wanted.push_back(s.name);
    } else if (cl.Flag("--record-id")) o.record_id = true;
    else if (cl.Flag("--scenario")) {
      const std::string v = cl.Value();
      if (std::none_of(scenarios.begin(), scenarios.end(), [&](const Scenario& s) { return s.name == v; }))
        cl.BadValue("a scenario --list shows", v);
      wanted.push_back(v);
    } else if (cl.Flag("--out")) o.out_dir = cl.Value();
    else if (cl.Flag("--gains")) o.gains_source = cl.Value();
    else if (cl.Flag("--disturbance-observer")) o.disturbance_observer = true;
    else cl.Unknown();
  }
  if (o.list) return o;
  for (const auto& s : scenarios)
    if (all || std::find(wanted.begin(), wanted.end(), s.name) != wanted.end()) o.run.push_back(&s);
  if (o.run.empty()) cl.Fail("nothing to run: expected --all, --patch or --scenario NAME");
  o.profile = plant.Profile();
  // the feedback gains every scenario's controller runs with
  if (o.gains_source != "untuned") {
    const std::string path = o.gains_source == "tuned" ? hyq::cli::DefaultSimServoConfig() : o.gains_source;
    try {
      o.gains = config::LoadServoConfig(path).controller;
    } catch (const std::exception& e) {
      cl.Fail("--gains " + o.gains_source + ": " + e.what());
    }
  }
  return o;
}

int Run(const Options& o) {
  const std::vector<const Scenario*>& run = o.run;
  const std::string& out_dir = o.out_dir;
  const std::optional<servo::ControllerConfig>& gains = o.gains;
  const dynamics::Model model = dynamics::LoadModelFromUrdf(hyq::cli::DefaultUrdf());
  const hal::HalConfig hal_config = config::LoadHalConfig(hyq::cli::DefaultHalConfig());
  std::filesystem::create_directories(out_dir);
  nlohmann::json results = nlohmann::json::object();
  const auto t_all = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < run.size(); ++i) {
    const Scenario& s = *run[i];
    const auto t0 = std::chrono::steady_clock::now();
    experiment::ExperimentConfig cfg = s.cfg;
    cfg.record_id_inputs = o.record_id && cfg.controller.kind != ControllerKind::kPid;
    if (gains) {
      cfg.controller.pid = gains->pid;
      cfg.controller.feedback = gains->feedback;
      cfg.controller.pd_gravity = gains->pd_gravity;
      // controller.gains.swing_scale, pid_swing_scale, pdg_swing_scale
      cfg.controller.swing_gain_scale = gains->swing_gain_scale;
      cfg.controller.pid_swing_gain_scale = gains->pid_swing_gain_scale;
      cfg.controller.pdg_swing_gain_scale = gains->pdg_swing_gain_scale;
    }
    cfg.disturbance.enabled = o.disturbance_observer;
    cfg.profile = o.profile;
    cfg.joints.assign(hal_config.joints.begin(), hal_config.joints.end());
    const auto r = experiment::RunExperiment(model, cfg, [&](double f) {
      std::fprintf(stderr, "\r[%zu/%zu] %-26s %3.0f %%", i + 1, run.size(), s.name.c_str(), 100 * f);
    });
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    experiment::WriteCsv(r, out_dir + "/" + s.name + ".csv");
    if (cfg.record_id_inputs) {
      std::ofstream id_file(out_dir + "/" + s.name + ".id.jsonl");
      servo::IdRecord rec;
      rec.controller = cfg.controller.kind;
      for (const auto& in : r.id_inputs) {
        rec.input = in;
        id_file << servo::FormatIdRecord(rec) << '\n';
      }
    }
    std::vector<double> us, qp_us;
    for (const auto& smp : r.samples) {
      us.push_back(smp.control_time_us);
      qp_us.push_back(smp.qp_time_us);
    }
    std::sort(qp_us.begin(), qp_us.end());
    double qp_mean = 0;
    for (double u : qp_us) qp_mean += u;
    qp_mean /= static_cast<double>(qp_us.size());
    auto qpct = [&](double p) { return qp_us[std::min(qp_us.size() - 1, static_cast<std::size_t>(p * qp_us.size()))]; };
    std::sort(us.begin(), us.end());
    double mean_us = 0;
    for (double u : us) mean_us += u;
    mean_us /= static_cast<double>(us.size());
    auto pct = [&](double p) { return us[std::min(us.size() - 1, static_cast<std::size_t>(p * us.size()))]; };
    results[s.name] = {{"mean_error_rad", r.mean_error_rad},
                       {"max_error_rad", r.max_error_rad},
                       {"mean_slip_speed_m_s", r.mean_slip_speed},
                       {"fell", r.fell},
                       {"fell_at_s", r.fell_at_s},
                       {"control_us", {{"mean", mean_us}, {"median", pct(0.5)}, {"p999", pct(0.999)}, {"max", us.back()}}},
                       {"qp_us", {{"mean", qp_mean}, {"median", qpct(0.5)}, {"p999", qpct(0.999)}, {"max", qp_us.back()}}},
                       {"torque_total_variation_Nm", r.torque_total_variation},
                       {"fallbacks", {{"stage1_failed", r.fallbacks.stage1_failed}, {"stage2_failed", r.fallbacks.stage2_failed}}},
                       {"realtime_factor", s.cfg.duration_s / wall},
                       {"profile", nlohmann::json::parse(o.profile.Json())},
                       {"gains", o.gains_source},
                       {"disturbance_observer", o.disturbance_observer}};
    if (!s.cfg.patches.empty()) {
      nlohmann::json settling = nlohmann::json::array();
      for (const auto& st : r.settling)
        settling.push_back({{"foot", st.foot}, {"t_s", st.t_s}, {"from_mu", st.from_mu},
                            {"to_mu", st.to_mu}, {"footfalls", st.footfalls}, {"lag_s", st.lag_s}});
      results[s.name]["patch"] = {{"mu_source", experiment::ToString(s.cfg.mu_source)},
                                  {"cycles", r.patch_cycles},
                                  {"mean_error_rad", r.patch_mean_error_rad},
                                  {"mean_slip_speed_m_s", r.patch_mean_slip_speed},
                                  {"settling", settling}};
    }
    std::fprintf(stderr, "\r[%zu/%zu] %-26s mean error %.4f rad, slip %.4f m/s%s, %.0fx real time\n",
                 i + 1, run.size(), s.name.c_str(), r.mean_error_rad, r.mean_slip_speed,
                 r.fell ? " FELL" : "", s.cfg.duration_s / wall);
  }
  WriteTables(results, out_dir);
  // the figures (Debian matplotlib); a missing Python only costs the PNGs
  const std::string plot = "/usr/bin/python3 " + hyq::cli::DataFile(HYQ_PLOT_SCRIPT, "plot_experiment.py") + " '" + out_dir + "'";
  if (std::system(plot.c_str()) != 0)
    std::fprintf(stderr, "hyq-experiment: the figures were not made (%s failed)\n", plot.c_str());
  std::fprintf(stderr, "done in %.1f s: %s/results.json\n",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t_all).count(),
               out_dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<Scenario> scenarios = Scenarios();
  cli::CommandLine cl(argc, argv, "hyq-experiment", hyq::cli::WithPaths(std::string(kUsage)));
  const Options o = Parse(cl, scenarios);
  if (o.list) {
    for (const auto& s : scenarios) std::printf("%s\n", s.name.c_str());
    return 0;
  }
  return cli::Run("hyq-experiment", [&] { return Run(o); });
}
