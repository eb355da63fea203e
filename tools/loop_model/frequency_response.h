// The frequency response of a system sampled once per period T, measured by driving it: a sine
// x[n] = a sin(θ n), θ = 2π f T, over a settling stretch and then a window of W samples holding
// exactly c whole cycles (f = c / (W T), so that the window is one bin of its DFT and nothing
// leaks from the other harmonics), and
//   H(e^{jθ}) = Y(θ) / X(θ),   X(θ) = Σ_n x[n] e^{−jθn} over the window (Y the same of y)   (1)
// the ratio of the fundamentals: exact for a linear system, the describing function of the
// amplitude a otherwise. It is how the hydraulic actuator (sim/hydraulic_actuator.h) is put into
// the loop model: the class itself, driven, rather than a formula derived from its equations.
#pragma once

#include <complex>
#include <functional>
#include <vector>

namespace hyq::loop_model {

struct ResponsePoint {
  double f_hz = 0.0;
  std::complex<double> value;
};

/// The sine and the window measuring near `f_hz`: c ≥ min_cycles cycles in W ≥ min_samples
/// samples, W prime (no harmonic below the (W − 1)-th aliases onto the fundamental),
/// f = c / (W T) the frequency measured.
struct SineWindow {
  int samples = 0;
  int cycles = 0;
  double f_hz = 0.0;
};
SineWindow WindowNear(double f_hz, double period_s, int min_cycles = 3, int min_samples = 100);

/// One sample of the system: input x at sample n of a sine of angle θ per sample (the system
/// may derive other inputs from them, e.g. a joint angle from its velocity); returns y[n].
using SampleStep = std::function<double(long n, double theta_rad, double x)>;

/// (1) at the window's frequency, after `settle` samples of the same sine; `step` starts from
/// the state the caller gave it.
std::complex<double> MeasureResponse(const SampleStep& step, const SineWindow& w, double amplitude,
                                     int settle);

/// `count` frequencies, log-spaced from f_lo to f_hi (each moved to its window's bin).
std::vector<SineWindow> LogSpacedWindows(double f_lo_hz, double f_hi_hz, int count, double period_s);

}  // namespace hyq::loop_model
