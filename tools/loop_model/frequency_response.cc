#include "tools/loop_model/frequency_response.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace hyq::loop_model {
namespace {

bool IsPrime(int n) {
  if (n < 2) return false;
  for (int d = 2; d * d <= n; ++d)
    if (n % d == 0) return false;
  return true;
}

}  // namespace

SineWindow WindowNear(double f_hz, double period_s, int min_cycles, int min_samples) {
  const double nyquist = 0.5 / period_s;
  if (!(f_hz > 0.0) || !(f_hz < nyquist))
    throw std::invalid_argument("frequency response: expected 0 < f < " + std::to_string(nyquist) +
                                " Hz, found " + std::to_string(f_hz));
  SineWindow w;
  // W samples holding `min_cycles` cycles, at least min_samples, W prime; then the whole cycles
  // nearest f. With W prime the m-th harmonic of a nonlinear response (m c cycles) never folds
  // back onto the fundamental's bin (m c ≡ ±c mod W needs W | m ∓ 1) for m < W − 1: at
  // θ = π/2 (f = 1/(4T)) the third harmonic would, and with it the seals' Coulomb friction.
  w.samples = std::max(min_samples, static_cast<int>(std::ceil(min_cycles / (f_hz * period_s))));
  while (!IsPrime(w.samples)) ++w.samples;
  w.cycles = std::max(1, static_cast<int>(std::lround(f_hz * period_s * w.samples)));
  if (2 * w.cycles >= w.samples) w.cycles = (w.samples - 1) / 2;  // below Nyquist
  w.f_hz = w.cycles / (w.samples * period_s);
  return w;
}

std::complex<double> MeasureResponse(const SampleStep& step, const SineWindow& w, double amplitude,
                                     int settle) {
  const double theta = 2.0 * std::numbers::pi * w.cycles / w.samples;
  std::complex<double> X = 0.0, Y = 0.0;
  for (long n = 0; n < settle + w.samples; ++n) {
    const double x = amplitude * std::sin(theta * static_cast<double>(n));
    const double y = step(n, theta, x);
    if (n < settle) continue;
    // (1): the window's DFT bin, phase referred to n = 0
    const std::complex<double> e = std::polar(1.0, -theta * static_cast<double>(n));
    X += x * e;
    Y += y * e;
  }
  return Y / X;
}

std::vector<SineWindow> LogSpacedWindows(double f_lo_hz, double f_hi_hz, int count, double period_s) {
  std::vector<SineWindow> out;
  for (int i = 0; i < count; ++i) {
    const double f = f_lo_hz * std::pow(f_hi_hz / f_lo_hz, count > 1 ? static_cast<double>(i) / (count - 1) : 0.0);
    const SineWindow w = WindowNear(f, period_s);
    if (out.empty() || w.f_hz > out.back().f_hz) out.push_back(w);
  }
  return out;
}

}  // namespace hyq::loop_model
