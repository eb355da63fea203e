// hyq-loop-model: the delay margin of every joint's feedback loop, predicted from the robot's
// inertia, the plant's actuator and the loop's delays (tools/loop_model/, docs/tuning.md "Loop
// model"), for the gains of a servo configuration or given on the command line.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/servo_config_loader.h"
#include "dynamics/urdf_loader.h"
#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"
#include "tools/loop_model/gain_search.h"
#include "tools/loop_model/loop_model.h"

namespace {

using namespace hyq;
using namespace hyq::loop_model;

constexpr std::string_view kUsage =
    "usage: hyq-loop-model [--config FILE] [--controller KIND] [--kp V[,V,V]] [--kd V[,V,V]]\n"
    "                      [--swing-scale S] [--plant ideal|realistic|both] [--delay-cycles K]\n"
    "                      [--actuator-tau S] [--velocity-cutoff HZ] [--mechanics euler|zoh]\n"
    "                      [--search] [--json FILE] [--plot PNG]\n"
    "\n"
    "Predicts the stability margins of each joint's PD loop, per joint type (haa, hfe, kfe), gait\n"
    "phase (swing: the leg in the air; stance: the trot's diagonal pair on the ground; stand: all\n"
    "four feet) and plant (ideal: hyq-sim's first-order actuator lag; realistic: HyQ's hydraulics\n"
    "with the boards' torque loop, measured by driving sim/hydraulic_actuator's class, and the\n"
    "profile's 1-cycle transport delay), at the 1 kHz rate: crossover, phase and gain margin, the\n"
    "delay margin (the extra delay, ms, before instability, and in whole cycles from it), and the\n"
    "exact number of extra cycles the discrete loop stays stable with (its closed-loop roots).\n"
    "Each line is the leg with the least margin; --json has every joint. docs/tuning.md explains\n"
    "the model; docs/baselines.md has the measured delay sweep beside it.\n"
    "\n"
    "  --config FILE        the servo configuration whose controller gains are modelled\n"
    "                       (default: @config@/hyq_servo_sim.yaml)\n"
    "  --controller KIND    two_stage, pid or pd_gravity (also noslip, stage1: the IDs' gains);\n"
    "                       default: the configuration's controller.kind\n"
    "  --kp V[,V,V]         the stance kp, N m/rad: one value for all joints or haa,hfe,kfe\n"
    "  --kd V[,V,V]         the stance kd, N m s/rad, the same way\n"
    "  --swing-scale S      kp and kd on a swing leg x S (0.05..1; default: the configuration's)\n"
    "  --plant P            ideal, realistic or both (default both)\n"
    "  --delay-cycles K     the extra delay (cycles beyond the plant's own) at which each loop's\n"
    "                       stability and dominant root are reported, 0..30 (default 2); hyq-sim's\n"
    "                       --delay-cycles is K on the ideal plant, K + 1 on the realistic one\n"
    "  --actuator-tau S     the ideal plant's lag, s (default 0.005, hyq-sim's)\n"
    "  --velocity-cutoff HZ the boards' velocity low-pass (default 250; 0: none)\n"
    "  --mechanics M        euler: MuJoCo's semi-implicit Euler step, what hyq-sim does (default);\n"
    "                       zoh: the continuous joint behind a zero-order hold, the robot\n"
    "  --search             also search per joint type the highest stance gains (the configured\n"
    "                       kp:kd ratio) and the swing scale that keep K extra cycles of margin\n"
    "                       on every plant asked for, in every phase, over the inertias' range\n"
    "  --json FILE          everything (every joint, the actuators' measured and fitted\n"
    "                       responses, the loops' frequency responses) as JSON\n"
    "  --plot PNG           Bode and Nyquist plots of the table's loops (needs /usr/bin/python3\n"
    "                       with matplotlib; tools/hyq-loop-model/plot_loop_model.py)\n"
    "  --help               this text\n"
    "\n"
    "exit status: 0 done, 1 a configuration or model error, 2 usage error\n";

struct Options {
  std::string config = hyq::cli::DefaultSimServoConfig();
  std::optional<servo::ControllerKind> controller;
  std::vector<double> kp, kd;
  std::optional<double> swing_scale;
  std::vector<PlantKind> plants{PlantKind::kIdeal, PlantKind::kRealistic};
  int delay_cycles = 2;
  double actuator_tau_s = 0.005;
  double velocity_cutoff_hz = 250.0;
  Mechanics mechanics = Mechanics::kSemiImplicitEuler;
  bool search = false;
  std::string json, plot;
};

// "V" or "V,V,V", each a number in [0, max]
std::vector<double> GainList(cli::CommandLine& cl, double max, std::string_view unit) {
  const std::string text = cl.Value();
  const std::string expected =
      "1 or 3 numbers (haa,hfe,kfe) in [0, " + std::to_string(static_cast<int>(max)) + "] " +
      std::string(unit);
  std::vector<double> out;
  const std::vector<std::string> parts = cli::Split(text, ',');
  if (parts.size() != 1 && parts.size() != 3) cl.BadValue(expected, text);
  for (const std::string& p : parts) {
    const std::optional<double> v = cli::ParseNumber(p);
    if (!v || *v < 0 || *v > max) cl.BadValue(expected, text);
    out.push_back(*v);
  }
  return out;
}

Options Parse(int argc, char** argv) {
  Options o;
  cli::CommandLine cl(argc, argv, "hyq-loop-model", hyq::cli::WithPaths(std::string(kUsage)));
  while (cl.Next()) {
    if (cl.Flag("--config")) {
      o.config = cl.Value();
    } else if (cl.Flag("--controller")) {
      const std::string v = cl.Value();
      o.controller = servo::ParseControllerKind(v);
      if (!o.controller) cl.BadValue("a controller two_stage, pid, pd_gravity, noslip or stage1", v);
    } else if (cl.Flag("--kp")) {
      o.kp = GainList(cl, servo::kMaxKpTau, "N m/rad");
    } else if (cl.Flag("--kd")) {
      o.kd = GainList(cl, servo::kMaxKdTau, "N m s/rad");
    } else if (cl.Flag("--swing-scale")) {
      o.swing_scale = cl.Number(0.05, 1.0);
    } else if (cl.Flag("--plant")) {
      const std::string v = cl.Value();
      if (v == "ideal") o.plants = {PlantKind::kIdeal};
      else if (v == "realistic") o.plants = {PlantKind::kRealistic};
      else if (v == "both") o.plants = {PlantKind::kIdeal, PlantKind::kRealistic};
      else cl.BadValue("a plant ideal, realistic or both", v);
    } else if (cl.Flag("--delay-cycles")) {
      o.delay_cycles = static_cast<int>(cl.Integer(0, 30));
    } else if (cl.Flag("--actuator-tau")) {
      o.actuator_tau_s = cl.Number(0.0, 1.0, "seconds in [0, 1]");
    } else if (cl.Flag("--velocity-cutoff")) {
      o.velocity_cutoff_hz = cl.Number(0.0, 499.0, "Hz in [0, 499] (0: no filter)");
    } else if (cl.Flag("--mechanics")) {
      const std::string v = cl.Value();
      if (v == "euler") o.mechanics = Mechanics::kSemiImplicitEuler;
      else if (v == "zoh") o.mechanics = Mechanics::kZeroOrderHold;
      else cl.BadValue("euler or zoh", v);
    } else if (cl.Flag("--search")) {
      o.search = true;
    } else if (cl.Flag("--json")) {
      o.json = cl.Text(1, 4096);
    } else if (cl.Flag("--plot")) {
      o.plot = cl.Text(1, 4096);
    } else if (cl.IsOption()) {
      cl.Unknown();
    } else {
      cl.Bad("argument", "no positional arguments", cl.arg());
    }
  }
  return o;
}

// 1 or 3 values over the 12 joints
void Apply(const std::vector<double>& v, dynamics::VectorJ* out) {
  if (v.empty()) return;
  for (int j = 0; j < dynamics::kNumJoints; ++j)
    (*out)(j) = v.size() == 1 ? v[0] : v[static_cast<std::size_t>(j % dynamics::kJointsPerLeg)];
}

std::string JointType(int joint) { return dynamics::kLegJointNames[static_cast<std::size_t>(joint % 3)]; }
std::string JointName(int joint) {
  return std::string(dynamics::kLegNames[static_cast<std::size_t>(joint / 3)]) + "_" + JointType(joint);
}

std::string Cycles(int k, int k_max) {
  if (k < 0) return "unstable";
  return k >= k_max ? ">=" + std::to_string(k_max) : std::to_string(k);
}

void PrintTable(const LoopModel& m, const std::vector<LoopRow>& worst, int report_k) {
  std::printf("| joint | phase | plant | I kg m^2 (range) | kp | kd | f_c Hz | PM deg | GM dB | "
              "delay margin ms | cycles (from ms) | cycles (exact; over I range) | +%d cycles: "
              "root |z|, Hz |\n",
              report_k);
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  const int kmax = m.settings.max_extra_cycles;
  for (const LoopRow& r : worst) {
    const Margins& mg = r.margins;
    const double dm_ms = 1e3 * mg.delay_margin_s;
    char dm_text[32], cyc_text[32], gm_text[32], fc_text[32], pm_text[32];
    if (std::isinf(dm_ms)) {
      std::snprintf(dm_text, sizeof dm_text, "inf");
      std::snprintf(cyc_text, sizeof cyc_text, "inf");
    } else {
      std::snprintf(dm_text, sizeof dm_text, "%.2f", dm_ms);
      std::snprintf(cyc_text, sizeof cyc_text, "%d", static_cast<int>(std::floor(mg.delay_margin_s / m.settings.period_s + 1e-9)));
    }
    if (std::isinf(mg.gain_margin)) std::snprintf(gm_text, sizeof gm_text, "inf");
    else std::snprintf(gm_text, sizeof gm_text, "%.1f", 20.0 * std::log10(mg.gain_margin));
    if (mg.has_crossover) {
      std::snprintf(fc_text, sizeof fc_text, "%.1f", mg.crossover_hz);
      std::snprintf(pm_text, sizeof pm_text, "%.1f", mg.phase_margin_deg);
    } else {
      std::snprintf(fc_text, sizeof fc_text, "-");
      std::snprintf(pm_text, sizeof pm_text, "-");
    }
    std::printf("| %s (%s) | %s | %s | %.4g (%.4g-%.4g) | %.1f | %.2f | %s | %s | %s | %s | %s | "
                "%s; %s | %.3f, %.1f%s |\n",
                JointType(r.joint).c_str(), JointName(r.joint).c_str(), ToString(r.phase),
                ToString(r.plant), r.inertia_kgm2, r.inertia_min, r.inertia_max, r.kp, r.kd,
                fc_text, pm_text, gm_text, dm_text, cyc_text, Cycles(r.max_extra_cycles, kmax).c_str(),
                Cycles(r.max_extra_cycles_over_range, kmax).c_str(), r.root_at_report.magnitude,
                r.root_at_report.frequency_hz, r.stable_at_report ? "" : " UNSTABLE");
  }
}

nlohmann::json RowJson(const LoopRow& r, double T) {
  const auto finite = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  return {{"joint", JointName(r.joint)},
          {"type", JointType(r.joint)},
          {"phase", ToString(r.phase)},
          {"plant", ToString(r.plant)},
          {"inertia_kgm2", r.inertia_kgm2},
          {"inertia_range_kgm2", {r.inertia_min, r.inertia_max}},
          {"kp", r.kp},
          {"kd", r.kd},
          {"ki", r.ki},
          {"plant_delay_cycles", r.plant_delay_cycles},
          {"crossover_hz", r.margins.has_crossover ? nlohmann::json(r.margins.crossover_hz) : nlohmann::json(nullptr)},
          {"phase_margin_deg", r.margins.has_crossover ? nlohmann::json(r.margins.phase_margin_deg) : nlohmann::json(nullptr)},
          {"gain_margin_db", std::isfinite(r.margins.gain_margin) ? nlohmann::json(20.0 * std::log10(r.margins.gain_margin)) : nlohmann::json(nullptr)},
          {"phase_crossover_hz", r.margins.phase_crossover_hz},
          {"delay_margin_ms", finite(1e3 * r.margins.delay_margin_s)},
          {"delay_margin_cycles_from_ms", std::isfinite(r.margins.delay_margin_s) ? nlohmann::json(std::floor(r.margins.delay_margin_s / T + 1e-9)) : nlohmann::json(nullptr)},
          {"max_extra_cycles_exact", r.max_extra_cycles},
          {"max_extra_cycles_exact_over_inertia_range", r.max_extra_cycles_over_range},
          {"dominant_root_at_report",
           {{"re", r.root_at_report.z.real()}, {"im", r.root_at_report.z.imag()},
            {"magnitude", r.root_at_report.magnitude}, {"frequency_hz", r.root_at_report.frequency_hz},
            {"stable", r.stable_at_report}}}};
}

// L(e^{jωT}) of a row's loop on a log grid, for the plots
nlohmann::json LoopResponse(const LoopModel& m, const LoopRow& r, int extra) {
  const ActuatorModel& a = m.actuators[static_cast<std::size_t>(r.plant)][static_cast<std::size_t>(r.phase)][static_cast<std::size_t>(r.joint)];
  const JointLoop loop = MakeJointLoop(m.settings, m.gains, a, r.joint, r.phase, r.inertia_kgm2);
  nlohmann::json f = nlohmann::json::array(), re = nlohmann::json::array(), im = nlohmann::json::array();
  const double T = m.settings.period_s;
  for (int i = 0; i < 400; ++i) {
    const double hz = 0.5 * std::pow(499.0 / 0.5, i / 399.0);
    const std::complex<double> l = OpenLoopAt(loop, extra, 2.0 * std::numbers::pi * hz * T);
    f.push_back(hz);
    re.push_back(l.real());
    im.push_back(l.imag());
  }
  return {{"extra_cycles", extra}, {"f_hz", f}, {"re", re}, {"im", im}};
}

nlohmann::json PointsJson(const std::vector<ResponsePoint>& pts, const TransferFunction& fit, double T) {
  nlohmann::json out = nlohmann::json::array();
  for (const ResponsePoint& p : pts) {
    const std::complex<double> h = fit.AtAngle(2.0 * std::numbers::pi * p.f_hz * T);
    out.push_back({p.f_hz, p.value.real(), p.value.imag(), h.real(), h.imag()});
  }
  return out;
}

int Run(const Options& o) {
  const servo::ServoConfig cfg = config::LoadServoConfig(o.config);
  const dynamics::Model model = dynamics::LoadModelFromUrdf(cfg.urdf);
  const servo::ControllerKind kind = o.controller.value_or(cfg.controller.kind);
  JointGains gains = GainsOf(cfg.controller, kind);
  Apply(o.kp, &gains.kp);
  Apply(o.kd, &gains.kd);
  if (o.swing_scale) gains.swing_scale = *o.swing_scale;

  LoopModelSettings s;
  s.period_s = cfg.hal.timing.cycle_period_s;
  s.actuator_tau_s = o.actuator_tau_s;
  s.velocity_cutoff_hz = o.velocity_cutoff_hz;
  s.mechanics = o.mechanics;
  s.report_extra_cycles = o.delay_cycles;
  s.trot = cfg.trot;
  const LoopModel m = BuildLoopModel(model, cfg.hal.joints, gains, s, o.plants);
  const std::vector<LoopRow> worst = WorstPerJointType(m.rows);

  std::printf("hyq-loop-model: %s, controller %s, %.0f Hz, mechanics %s, actuator lag %.1f ms "
              "(ideal), boards' velocity low-pass %.0f Hz\n",
              o.config.c_str(), servo::ToString(kind), 1.0 / s.period_s,
              s.mechanics == Mechanics::kSemiImplicitEuler ? "semi-implicit Euler (hyq-sim)" : "zero-order hold",
              1e3 * s.actuator_tau_s, s.velocity_cutoff_hz);
  std::printf("gains (haa, hfe, kfe of lf): kp %.1f %.1f %.1f, kd %.2f %.2f %.2f, ki %.1f %.1f %.1f, "
              "swing scale %.3g\n",
              gains.kp(0), gains.kp(1), gains.kp(2), gains.kd(0), gains.kd(1), gains.kd(2), gains.ki(0),
              gains.ki(1), gains.ki(2), gains.swing_scale);
  std::printf("delays: 1 cycle (the bus) + the plant's own (ideal 0, realistic 1) + K extra; "
              "extra cycles counted beyond those\n\n");
  PrintTable(m, worst, o.delay_cycles);

  nlohmann::json search_json;
  if (o.search) {
    const SearchResult r = SearchGains(m, o.delay_cycles);
    std::printf("\nsearch: per joint type, the highest stance gains (the configured kp:kd) and swing "
                "scale keeping >= %d extra cycles (exact, over the inertias' range) on %s:\n",
                o.delay_cycles, o.plants.size() == 2 ? "both plants" : ToString(o.plants[0]));
    for (int t = 0; t < 3; ++t) {
      const TypeGains& g = r.types[static_cast<std::size_t>(t)];
      const char* type = dynamics::kLegJointNames[static_cast<std::size_t>(t)];
      if (g.stance_factor > 0)
        std::printf("  %s stance: kp %.1f, kd %.2f (x %.3g of the configured; allowed from x %.3g; "
                    "above: %s)\n",
                    type, g.kp, g.kd, g.stance_factor, g.stance_min_factor, g.stance_limit.c_str());
      else
        std::printf("  %s stance: %s\n", type, g.stance_limit.c_str());
      if (g.swing_found)
        std::printf("  %s swing: scale %.3g (kp %.1f, kd %.2f; allowed from %.3g; above: %s)\n", type,
                    g.swing_scale, g.kp * g.swing_scale, g.kd * g.swing_scale, g.swing_min_scale,
                    g.swing_limit.c_str());
      else
        std::printf("  %s swing: no scale in [0.05, 1] keeps %d; the best, %.3g (kp %.1f, kd %.2f), "
                    "keeps %d on its worst plant; of any kp:kd, kp %.1f, kd %.2f keeps %d\n",
                    type, o.delay_cycles, g.swing_scale, g.kp * g.swing_scale, g.kd * g.swing_scale,
                    g.swing_worst_cycles, g.swing_best_kp, g.swing_best_kd, g.swing_best_cycles);
    }
    search_json = {{"required_extra_cycles", o.delay_cycles}};
    for (int t = 0; t < 3; ++t) {
      const TypeGains& g = r.types[static_cast<std::size_t>(t)];
      search_json[dynamics::kLegJointNames[static_cast<std::size_t>(t)]] = {
          {"stance_kp", g.kp}, {"stance_kd", g.kd}, {"stance_factor", g.stance_factor},
          {"stance_min_factor", g.stance_min_factor}, {"stance_limit", g.stance_limit},
          {"swing_found", g.swing_found}, {"swing_scale", g.swing_scale},
          {"swing_min_scale", g.swing_min_scale}, {"swing_limit", g.swing_limit},
          {"swing_worst_extra_cycles", g.swing_worst_cycles},
          {"swing_best_any_ratio", {{"kp", g.swing_best_kp}, {"kd", g.swing_best_kd},
                                    {"extra_cycles", g.swing_best_cycles}}}};
    }
  }

  if (!o.json.empty() || !o.plot.empty()) {
    const double T = s.period_s;
    nlohmann::json j;
    j["config"] = o.config;
    j["controller"] = servo::ToString(kind);
    j["settings"] = {{"period_s", T}, {"actuator_tau_s", s.actuator_tau_s},
                     {"velocity_cutoff_hz", s.velocity_cutoff_hz},
                     {"mechanics", s.mechanics == Mechanics::kSemiImplicitEuler ? "euler" : "zoh"},
                     {"report_extra_cycles", s.report_extra_cycles},
                     {"max_extra_cycles", s.max_extra_cycles}};
    j["gains"] = {{"kp", std::vector<double>(gains.kp.data(), gains.kp.data() + 12)},
                  {"kd", std::vector<double>(gains.kd.data(), gains.kd.data() + 12)},
                  {"ki", std::vector<double>(gains.ki.data(), gains.ki.data() + 12)},
                  {"swing_scale", gains.swing_scale}};
    for (int p = 0; p < kNumPhases; ++p) {
      const PhaseInertia& in = m.inertia[static_cast<std::size_t>(p)];
      nlohmann::json pj;
      for (int jt = 0; jt < dynamics::kNumJoints; ++jt) {
        pj[JointName(jt)] = {{"nominal", in.nominal(jt)}, {"min", in.min(jt)}, {"max", in.max(jt)}};
        if (p == 0) pj[JointName(jt)]["free_leg"] = in.free_leg(jt);
      }
      j["inertia_kgm2"][ToString(static_cast<Phase>(p))] = pj;
    }
    for (PlantKind plant : o.plants) {
      if (plant != PlantKind::kRealistic) continue;
      for (int p = 0; p < kNumPhases; ++p)
        for (int jt = 0; jt < dynamics::kNumJoints; ++jt) {
          const ActuatorModel& a = m.actuators[1][static_cast<std::size_t>(p)][static_cast<std::size_t>(jt)];
          j["hydraulics"][ToString(static_cast<Phase>(p))][JointName(jt)] = {
              {"operating_torque_Nm", a.operating_torque_Nm},
              {"setpoint_fit_max_rel_error", a.setpoint_fit_error},
              {"motion_fit_max_rel_error", a.motion_fit_error},
              {"setpoint_f_re_im_fitre_fitim", PointsJson(a.setpoint_measured, a.setpoint, T)},
              {"motion_f_re_im_fitre_fitim", PointsJson(a.motion_measured, a.motion, T)}};
        }
    }
    for (const LoopRow& r : m.rows) j["rows"].push_back(RowJson(r, T));
    for (const LoopRow& r : worst) {
      nlohmann::json w = RowJson(r, T);
      w["response"] = {LoopResponse(m, r, 0), LoopResponse(m, r, s.report_extra_cycles)};
      j["table"].push_back(w);
    }
    if (o.search) j["search"] = search_json;
    std::string path = o.json;
    if (path.empty()) path = (std::filesystem::temp_directory_path() / "hyq-loop-model.json").string();
    std::ofstream out(path);
    out << j.dump(1) << "\n";
    if (!out) throw std::runtime_error("cannot write " + path);
    out.close();
    if (!o.plot.empty()) {
      const std::string cmd = "/usr/bin/python3 " + hyq::cli::DataFile(HYQ_PLOT_SCRIPT, "plot_loop_model.py") + " '" + path + "' '" + o.plot + "'";
      if (std::system(cmd.c_str()) != 0)
        throw std::runtime_error("the plot was not made (" + cmd + " failed)");
      std::printf("\nplot: %s\n", o.plot.c_str());
    }
    if (!o.json.empty()) std::printf("json: %s\n", o.json.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = Parse(argc, argv);
  return cli::Run("hyq-loop-model", [&] { return Run(o); });
}
