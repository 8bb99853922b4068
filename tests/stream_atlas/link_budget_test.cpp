// LinkBudget (stream/link_budget.h) against an encoder that spends exactly its target: the bytes
// sent over a path stay within the link's, whatever the other sections do, as long as the video's
// floor leaves room; the floor holds under overload.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "mirage/stream/link_budget.h"

namespace mirage::stream {
namespace {

struct PathBytes {
  double total = 0;            // every byte sent
  double lastFrame = 0;        // the last frame's bytes
  double minVideo = 1e300;     // the smallest video target, bytes per frame
  double maxVideo = 0;         // the largest
  double worstPrefix = -1e300; // max over prefixes of (bytes sent - the link's bytes - the debt left)
};

// Plays `other` (the patch and particle sections' bytes of each frame) through a LinkBudget with
// an encoder that spends `spend` times its target.
PathBytes play(LinkBudget& link, const LinkBudgetConfig& config, const std::vector<double>& other, double spend = 1.0) {
  PathBytes run;
  double frames = 0;
  for (double o : other) {
    double video = double(link.videoKbps()) * 1000.0 / 8.0 / config.fps;
    run.minVideo = std::min(run.minVideo, video);
    run.maxVideo = std::max(run.maxVideo, video);
    double sent = std::floor(video * spend);
    link.account(uint64_t(sent), uint64_t(o));
    run.total += sent + o;
    run.lastFrame = sent + o;
    frames += 1;
    run.worstPrefix =
        std::max(run.worstPrefix, run.total - frames * link.frameBytes() - std::max(0.0, link.debtBytes()));
  }
  return run;
}

TEST(LinkBudget, SteadySectionsLeaveTheVideoTheRest) {
  LinkBudgetConfig config{.kbps = 20000, .fps = 60};
  LinkBudget link(config);
  const double frame = link.frameBytes();
  std::vector<double> other(240, 0.3 * frame);
  PathBytes run = play(link, config, other);
  EXPECT_LE(run.total, 240 * frame * 1.005) << "over the path";
  EXPECT_LE(run.lastFrame, frame * 1.005) << "settled";
  EXPECT_GE(run.lastFrame, frame * 0.98) << "the video takes what the sections leave";
}

TEST(LinkBudget, ABurstIsRepaid) {
  LinkBudgetConfig config{.kbps = 20000, .fps = 60};
  LinkBudget link(config);
  const double frame = link.frameBytes();
  std::vector<double> other(120, 0.2 * frame);
  other[0] = 5.0 * frame;  // the first frame's geometry
  other[60] = 2.0 * frame; // a camera cut
  PathBytes run = play(link, config, other);
  EXPECT_LE(run.total, 120 * frame * 1.01) << "debt " << link.debtBytes();
  EXPECT_GE(run.minVideo, 0.25 * frame * 0.999) << "the floor";
}

TEST(LinkBudget, OverloadKeepsTheFloor) {
  LinkBudgetConfig config{.kbps = 8000, .fps = 30};
  LinkBudget link(config);
  const double frame = link.frameBytes();
  std::vector<double> other(100, 0.9 * frame);
  PathBytes run = play(link, config, other);
  EXPECT_GE(run.minVideo, 0.25 * frame * 0.999);
  EXPECT_LE(run.minVideo, 0.25 * frame * 1.01) << "the sections alone fill the link: the video gets its floor";
}

TEST(LinkBudget, AnUndershootingEncoderGetsTheRestWithoutGoingOver) {
  LinkBudgetConfig config{.kbps = 20000, .fps = 60};
  LinkBudget link(config);
  const double frame = link.frameBytes();
  std::vector<double> other(240, 0.3 * frame);
  PathBytes run = play(link, config, other, 0.7); // x264 spends about 70 % of its target
  EXPECT_LE(run.total, 240 * frame) << "a credit is earned before it is spent";
  EXPECT_GE(run.total, 240 * frame * 0.95) << "the unspent bytes raise the targets";
  EXPECT_GT(run.maxVideo, 0.7 * frame * 1.2) << "the target rises above what the sections leave";
  EXPECT_LE(run.maxVideo, 2.0 * frame * 1.001) << "the ceiling";
}

TEST(LinkBudget, NoPrefixGoesOverByMoreThanItsDebt) {
  LinkBudgetConfig config{.kbps = 12000, .fps = 30};
  LinkBudget link(config);
  const double frame = link.frameBytes();
  std::vector<double> other(300);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> share(0.0, 0.6);
  for (double& o : other) o = std::floor(share(rng) * frame); // whole bytes, as sections are
  for (size_t i = 0; i < other.size(); i += 50) other[i] = 3.0 * frame; // cuts
  PathBytes run = play(link, config, other, 0.8);
  EXPECT_LE(run.worstPrefix, 1.0) << "bytes";
}

} // namespace
} // namespace mirage::stream
