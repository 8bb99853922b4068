// Frame-time control against a synthetic GPU: frame time = a + b / tau^2 (fixed cost plus work
// proportional to the triangles of a cut at error tau). No real GPU time is measured here.
#include <cmath>
#include <cstddef>
#include <deque>
#include <vector>

#include <gtest/gtest.h>

#include "mirage/runtime/frame_time.h"

namespace mirage::runtime {
namespace {

struct Model {
  double a = 1.0;  // ms, independent of tau
  double b = 40.0; // ms at tau = 1
  double ms(float tau) const { return a + b / (double(tau) * double(tau)); }
};

struct Trace {
  std::vector<float> tau; // tau of each frame drawn
  std::vector<float> surfel;
  std::vector<double> ms; // its time
};

// Runs `frames` frames; `model(i)` gives frame i's model; `delay` frames in flight (the time of
// frame i reaches the controller before frame i + 1 + delay is chosen).
template <class ModelAt>
Trace run(const FrameTimeSettings& s, RenderConfig config, int frames, ModelAt&& model, int delay = 0) {
  FrameTimeState state = startFrameTime(s, config);
  applyFrameTime(s, state, config);
  Trace t;
  std::deque<std::pair<float, double>> inFlight;
  for (int i = 0; i < frames; ++i) {
    double ms = model(i).ms(config.tauPixels);
    t.tau.push_back(config.tauPixels);
    t.surfel.push_back(config.surfelSize);
    t.ms.push_back(ms);
    inFlight.push_back({config.tauPixels, ms});
    if (int(inFlight.size()) > delay) {
      updateFrameTime(s, state, inFlight.front().first, inFlight.front().second);
      inFlight.pop_front();
    }
    applyFrameTime(s, state, config);
  }
  return t;
}

bool within(double ms, double target, double fraction) { return std::abs(ms - target) <= fraction * target; }

// Frames from `from` on that are within +-10 % of the target.
bool allWithin(const Trace& t, double target, size_t from) {
  for (size_t i = from; i < t.ms.size(); ++i)
    if (!within(t.ms[i], target, 0.10)) return false;
  return true;
}

// Changes of direction of tau (a controller that oscillates reverses over and over).
int reversals(const std::vector<float>& tau, size_t from = 0) {
  int count = 0, last = 0;
  for (size_t i = from + 1; i < tau.size(); ++i) {
    int dir = tau[i] > tau[i - 1] ? 1 : tau[i] < tau[i - 1] ? -1 : 0;
    if (dir && last && dir != last) ++count;
    if (dir) last = dir;
  }
  return count;
}

FrameTimeSettings settings(double targetMs) {
  FrameTimeSettings s;
  s.targetMs = targetMs;
  return s;
}

RenderConfig atTau(float tau) {
  RenderConfig c;
  c.tauPixels = tau;
  return c;
}

TEST(FrameTime, ConvergesFromFineDetailWithoutOscillating) {
  Model m;                // 41 ms at tau 1
  auto s = settings(5.0); // needs tau = sqrt(40 / 4) = 3.16
  Trace t = run(s, atTau(1.0f), 200, [&](int) { return m; });
  EXPECT_GT(t.ms[0], 5.0 * 1.1);
  EXPECT_TRUE(allWithin(t, 5.0, 8)) << "not within 10 % after 8 frames";
  EXPECT_EQ(reversals(t.tau), 0); // approaches from one side: b/tau^2 + a never overshoots
  EXPECT_NEAR(t.tau.back(), std::sqrt(40.0 / 4.0), 0.35);
  // Once settled it holds still (hysteresis), not chasing the last percent.
  for (size_t i = 20; i < t.tau.size(); ++i) EXPECT_EQ(t.tau[i], t.tau[19]) << i;
}

TEST(FrameTime, ConvergesFromCoarseDetail) {
  Model m;
  auto s = settings(5.0);
  Trace t = run(s, atTau(16.0f), 200, [&](int) { return m; });
  EXPECT_LT(t.ms[0], 5.0 * 0.9);
  EXPECT_TRUE(allWithin(t, 5.0, 10));
  EXPECT_EQ(reversals(t.tau), 0);
}

TEST(FrameTime, TargetMetAtFinestDetailChangesNothing) {
  Model m{.a = 0.5, .b = 2.0}; // 2.5 ms at tau 1
  auto s = settings(4.0);
  Trace t = run(s, atTau(1.0f), 100, [&](int) { return m; });
  for (size_t i = 0; i < t.tau.size(); ++i) {
    EXPECT_EQ(t.tau[i], 1.0f) << i;
    EXPECT_EQ(t.surfel[i], s.surfelMin) << i;
  }
}

TEST(FrameTime, StaysInsideItsBounds) {
  auto s = settings(1.0);
  // Unreachable: even tau 16 costs more than the target (fixed cost 3 ms): tau pins at the max.
  Model heavy{.a = 3.0, .b = 1000.0};
  Trace t = run(s, atTau(1.0f), 100, [&](int) { return heavy; });
  for (size_t i = 0; i < t.tau.size(); ++i) {
    EXPECT_GE(t.tau[i], s.tauMin);
    EXPECT_LE(t.tau[i], s.tauMax);
    EXPECT_GE(t.surfel[i], s.surfelMin);
    EXPECT_LE(t.surfel[i], s.surfelMax);
  }
  EXPECT_EQ(t.tau.back(), s.tauMax);
  EXPECT_EQ(t.surfel.back(), s.surfelMax);
  // Trivial: from the coarsest, tau returns to the finest and stays.
  Model light{.a = 0.1, .b = 0.1};
  t = run(settings(10.0), atTau(16.0f), 100, [&](int) { return light; });
  EXPECT_EQ(t.tau.back(), s.tauMin);
  for (float tau : t.tau) EXPECT_GE(tau, s.tauMin);
  // Garbage timings (a lost query) change nothing.
  FrameTimeState state = startFrameTime(s, atTau(4.0f));
  for (double bad : {0.0, -1.0, double(NAN), double(INFINITY)}) updateFrameTime(s, state, 4.0f, bad);
  EXPECT_FLOAT_EQ(frameTimeTau(s, state), 4.0f);
  EXPECT_EQ(state.updates, 0u);
}

TEST(FrameTime, RecoversQuicklyFromAStepInLoad) {
  auto s = settings(5.0);
  // The camera turns towards twice the geometry at frame 50, and away again at 100.
  auto model = [](int i) { return Model{.a = 1.0, .b = i >= 50 && i < 100 ? 80.0 : 40.0}; };
  Trace t = run(s, atTau(1.0f), 150, model);
  for (size_t i = 58; i < 100; ++i) EXPECT_TRUE(within(t.ms[i], 5.0, 0.10)) << i << ": " << t.ms[i];
  for (size_t i = 108; i < 150; ++i) EXPECT_TRUE(within(t.ms[i], 5.0, 0.10)) << i << ": " << t.ms[i];
  EXPECT_LE(reversals(t.tau), 2); // up once, down once (and the start)
  EXPECT_NEAR(t.tau[99], std::sqrt(80.0 / 4.0), 0.5);
}

TEST(FrameTime, FramesInFlightDoNotMakeItOscillate) {
  auto s = settings(5.0);
  Model m;
  for (int delay : {1, 2, 3}) {
    Trace t = run(
        s, atTau(1.0f), 200, [&](int) { return m; }, delay);
    EXPECT_TRUE(allWithin(t, 5.0, 20)) << "delay " << delay;
    EXPECT_LE(reversals(t.tau), 1) << "delay " << delay;
  }
}

TEST(FrameTime, NoisyTimingsDoNotMoveASettledTau) {
  auto s = settings(5.0);
  Model m;
  uint32_t rng = 12345;
  auto noisy = [&](int) { // +-3 % per frame (deterministic)
    rng = rng * 1664525u + 1013904223u;
    double n = (double(rng >> 8) / double(1u << 24)) * 0.06 - 0.03;
    return Model{.a = m.a * (1 + n), .b = m.b * (1 + n)};
  };
  Trace t = run(s, atTau(1.0f), 300, noisy);
  EXPECT_TRUE(allWithin(t, 5.0, 10));
  EXPECT_LE(reversals(t.tau, 20), 2);
}

TEST(FrameTime, SettingsAreChecked) {
  EXPECT_FALSE(validate(settings(0.0)));
  EXPECT_FALSE(validate(settings(-3.0)));
  EXPECT_FALSE(validate(settings(double(NAN))));
  EXPECT_NE(validate(settings(0.0)).error().message.find("--target-ms"), std::string::npos);
  EXPECT_TRUE(validate(settings(2.0)));
  auto s = settings(2.0);
  s.tauMax = 0.5f;
  EXPECT_FALSE(validate(s));
  s = settings(2.0);
  s.surfelMin = 0.1f;
  EXPECT_FALSE(validate(s));
}

} // namespace
} // namespace mirage::runtime
