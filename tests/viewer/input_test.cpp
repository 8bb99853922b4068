// The viewer's input handling without a window: the key table, the fly input of a frame (overlay
// capture, mouse look, wheel, stall clamp), the switches keys flip, a scripted input session through
// the loop's own calls, and the frame figures.
#include <set>
#include <vector>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <gtest/gtest.h>

#include "frame_log.h"
#include "keys.h"
#include "mirage/viewer/fly_camera.h"

using namespace mirage;
using namespace mirage::viewer;

TEST(ViewerKeys, EveryActionHasOneKeyAndNoKeyTwoMeanings) {
  std::set<int> keys, actions;
  for (const KeyBinding& b : keyBindings()) {
    EXPECT_TRUE(keys.insert(b.key).second) << b.name << " bound twice";
    EXPECT_TRUE(actions.insert(int(b.action)).second) << b.what << " has two keys";
    ASSERT_TRUE(actionOfKey(b.key));
    EXPECT_EQ(*actionOfKey(b.key), b.action);
  }
  EXPECT_EQ(actions.size(), size_t(Action::Surfels) + 1); // every enumerator
  for (int k : flyKeys()) {
    EXPECT_FALSE(actionOfKey(k)) << "fly key " << k << " also triggers an action";
    EXPECT_FALSE(keys.count(k));
  }
}

TEST(ViewerKeys, TheKeysTheDocsList) {
  EXPECT_EQ(actionOfKey(GLFW_KEY_F), Action::FrameScene);
  EXPECT_EQ(actionOfKey(GLFW_KEY_C), Action::CopyCamera);
  EXPECT_EQ(actionOfKey(GLFW_KEY_R), Action::Record);
  EXPECT_EQ(actionOfKey(GLFW_KEY_P), Action::Replay);
  EXPECT_EQ(actionOfKey(GLFW_KEY_F12), Action::Screenshot);
  EXPECT_EQ(actionOfKey(GLFW_KEY_V), Action::Vsync);
  EXPECT_EQ(actionOfKey(GLFW_KEY_T), Action::Transparency);
  EXPECT_EQ(actionOfKey(GLFW_KEY_U), Action::Surfels);
  EXPECT_EQ(actionOfKey(GLFW_KEY_ESCAPE), Action::Close);
  EXPECT_FALSE(actionOfKey(GLFW_KEY_X));
  const int wasdqe[] = {GLFW_KEY_W, GLFW_KEY_A, GLFW_KEY_S, GLFW_KEY_D, GLFW_KEY_Q, GLFW_KEY_E};
  ASSERT_EQ(flyKeys().size(), 6u);
  for (size_t i = 0; i < 6; ++i) EXPECT_EQ(flyKeys()[i], wasdqe[i]);
}

TEST(ViewerKeys, SwitchesFlipOnlyWhatTheSceneHas) {
  UiState s;
  EXPECT_TRUE(s.config.transparency);
  EXPECT_FALSE(applySwitch(Action::Transparency, s)); // no BLEND materials: nothing to switch
  EXPECT_TRUE(s.config.transparency);
  s.hasBlend = true;
  EXPECT_TRUE(applySwitch(Action::Transparency, s));
  EXPECT_FALSE(s.config.transparency);
  EXPECT_TRUE(applySwitch(Action::Transparency, s));
  EXPECT_TRUE(s.config.transparency);
  EXPECT_FALSE(applySwitch(Action::Surfels, s));
  s.mixed = true;
  EXPECT_TRUE(applySwitch(Action::Surfels, s));
  EXPECT_FALSE(s.config.drawSurfels);
  bool vsync = s.vsync;
  EXPECT_TRUE(applySwitch(Action::Vsync, s));
  EXPECT_NE(s.vsync, vsync);
  EXPECT_FALSE(applySwitch(Action::Screenshot, s)); // the loop's, not a switch
}

TEST(ViewerInput, KeysMoveUnlessTheOverlayHasTheKeyboard) {
  InputState in;
  in.forward = true;
  in.up = true;
  FlyInput f = flyInput(in, false, 0.1f);
  EXPECT_EQ(f.move, glm::vec3(0, 1, 1));
  EXPECT_FLOAT_EQ(f.seconds, 0.1f);
  in.overlayKeyboard = true;
  EXPECT_EQ(flyInput(in, false, 0.1f).move, glm::vec3(0));
}

TEST(ViewerInput, MouseLooksOnlyWhileLookingWhichStartsOutsideTheOverlay) {
  InputState in;
  in.mouseDelta = {4, -2};
  EXPECT_EQ(flyInput(in, false, 0.0f).look, glm::vec2(0)); // a moving cursor alone does not turn
  EXPECT_EQ(flyInput(in, true, 0.0f).look, glm::vec2(4, -2));
  in.lookButton = true;
  in.overlayMouse = true;
  EXPECT_FALSE(nextLooking(false, in)); // pressed over the overlay: the overlay's drag
  EXPECT_TRUE(nextLooking(true, in));   // looking already: the cursor may cross the overlay
  in.overlayMouse = false;
  EXPECT_TRUE(nextLooking(false, in));
  in.lookButton = false;
  EXPECT_FALSE(nextLooking(true, in)); // released
}

TEST(ViewerInput, WheelSetsSpeedUnlessOverTheOverlayAndStallsAreClamped) {
  InputState in;
  in.scroll = 2.0f;
  FlyCamera c;
  c.speed = 1.0f;
  update(c, flyInput(in, false, 0.0f));
  EXPECT_NEAR(c.speed, kSpeedStepPerNotch * kSpeedStepPerNotch, 1e-6f);
  in.overlayMouse = true; // scrolling the overlay's panel
  update(c, flyInput(in, false, 0.0f));
  EXPECT_NEAR(c.speed, kSpeedStepPerNotch * kSpeedStepPerNotch, 1e-6f);
  in = {};
  in.right = true;
  c = FlyCamera{};
  glm::vec3 start = c.position;
  update(c, flyInput(in, false, 5.0f)); // a five-second stall moves a quarter second's worth
  EXPECT_NEAR(glm::length(c.position - start), c.speed * kMaxStepSeconds, 1e-5f);
  EXPECT_EQ(flyInput(in, false, -1.0f).seconds, 0.0f);
}

TEST(ViewerFrameLog, MeanAndNearestRank95thPercentile) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(double(i));
  Figure f = figure(v);
  EXPECT_EQ(f.count, 100u);
  EXPECT_DOUBLE_EQ(f.mean, 50.5);
  EXPECT_DOUBLE_EQ(f.p95, 95.0);
  EXPECT_DOUBLE_EQ(figure(std::vector<double>{7.0}).p95, 7.0);
  EXPECT_EQ(figure({}).count, 0u);
  EXPECT_DOUBLE_EQ(recentMean(v, 2), 1.5); // the last two: 2 and 1
  EXPECT_DOUBLE_EQ(recentMean({}), 0.0);
}

TEST(ViewerFrameLog, SummaryIsOneLineWithFpsFrameTimesAndLatency) {
  FrameLog log;
  log.frameMs = {10, 20, 30, 40};
  log.inputToPresentMs = {5, 15};
  log.inputToSubmitMs = {4, 6};
  log.submitToGpuMs = {1, 3};
  log.gpuFrameMs = {2, 8, 4};
  std::string line = summaryLine(log, 4, 2.0, "dev");
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_NE(line.find("viewed 4 frames in 2.00 s: 2.0 FPS"), std::string::npos) << line;
  EXPECT_NE(line.find("frame mean 25.0 ms p95 40.0 ms"), std::string::npos) << line;
  EXPECT_NE(line.find("input->present mean 10.0 ms p95 15.0 ms"), std::string::npos) << line;
  EXPECT_NE(line.find("input->submit 5.0 ms, submit->GPU done 2.0 ms"), std::string::npos) << line;
  EXPECT_NE(line.find("GPU frame median 4.000 ms (dev)"), std::string::npos) << line;
  log.tau = {1, 2, 6};
  line = summaryLine(log, 4, 2.0, "dev");
  EXPECT_NE(line.find("GPU frame median 4.000 ms, tau mean 3.00 px (1.00..6.00) (dev)"), std::string::npos) << line;
}

TEST(ViewerKeys, KeyScriptNamesActionsAtFrames) {
  auto s = parseKeyScript("C@1,F12@2,R@3,R@10");
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(s->size(), 4u);
  EXPECT_EQ((*s)[0].action, Action::CopyCamera);
  EXPECT_EQ((*s)[0].frame, 1u);
  EXPECT_EQ((*s)[1].action, Action::Screenshot);
  EXPECT_EQ((*s)[3].action, Action::Record);
  EXPECT_EQ((*s)[3].frame, 10u);
  EXPECT_TRUE(parseKeyScript("")->empty());
  for (const char* bad : {"X@1", "C", "C@", "C@-1", "C@1x", "@2", "C@1,,F@2"}) {
    auto r = parseKeyScript(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().message.find("--keys"), std::string::npos);
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  }
}

namespace {

// A scripted input session: events at frames, turned into each frame's PolledInput the way
// Window::poll turns GLFW's state into it (every key's state set each frame, so a held key is
// pressed only on its first frame), then through the viewer loop's calls in its order:
// frameActions, applySwitch for the switches, flyStep.
struct InputEvent {
  enum Kind { KeyDown, KeyUp, LookDown, LookUp, Move, Scroll };
  uint64_t frame = 0;
  Kind kind = KeyDown;
  int key = 0;
  glm::vec2 value{0.0f}; // Move: pixels; Scroll: notches in x
};

struct Session {
  FlyCamera fly;
  UiState ui;
  bool looking = false;
  std::vector<ScriptedKey> script;
  std::vector<std::pair<uint64_t, Action>> actions; // every action with its frame
  std::set<uint64_t> overlayKeyboard, overlayMouse; // frames the overlay holds them
};

void play(Session& s, const std::vector<InputEvent>& events, uint64_t frames, float seconds) {
  PolledInput input;
  std::array<bool, PolledInput::kKeys> held{};
  for (uint64_t frame = 0; frame < frames; ++frame) {
    input.mouseDelta = glm::vec2(0.0f);
    input.scroll = 0.0f;
    for (const InputEvent& e : events) {
      if (e.frame != frame) continue;
      if (e.kind == InputEvent::KeyDown || e.kind == InputEvent::KeyUp)
        held[size_t(e.key)] = e.kind == InputEvent::KeyDown;
      if (e.kind == InputEvent::LookDown || e.kind == InputEvent::LookUp)
        input.lookButton = e.kind == InputEvent::LookDown;
      if (e.kind == InputEvent::Move) input.mouseDelta += e.value;
      if (e.kind == InputEvent::Scroll) input.scroll += e.value.x;
    }
    for (int key = 0; key < PolledInput::kKeys; ++key) input.setKey(key, held[size_t(key)]);
    bool keyboard = s.overlayKeyboard.count(frame) > 0, mouse = s.overlayMouse.count(frame) > 0;
    for (Action a : frameActions(input, keyboard, s.script, frame)) {
      s.actions.push_back({frame, a});
      applySwitch(a, s.ui);
    }
    flyStep(input, keyboard, mouse, seconds, s.looking, s.fly);
  }
}

} // namespace

TEST(ViewerInput, AScriptedSessionMovesTurnsAndSwitchesAsTheLoopDoes) {
  constexpr float kDt = 0.1f;
  Session s;
  s.fly.speed = 2.0f; // 0.2 units per frame
  s.ui.hasBlend = true;
  s.ui.mixed = true;
  s.script = {{19, Action::Surfels}};
  s.overlayKeyboard = {20};
  s.overlayMouse = {21, 22, 23};
  const glm::vec3 start = s.fly.position;
  using E = InputEvent;
  std::vector<InputEvent> events = {
      {0, E::KeyDown, GLFW_KEY_W}, // 0-4: forward (-z)
      {5, E::KeyUp, GLFW_KEY_W},
      {5, E::KeyDown, GLFW_KEY_D},
      {5, E::KeyDown, GLFW_KEY_E}, // 5-9: right, up
      {10, E::KeyUp, GLFW_KEY_D},
      {10, E::KeyUp, GLFW_KEY_E},
      {10, E::LookDown},
      {10, E::Move, 0, {200, 0}},    // turn right 0.5 rad
      {11, E::Move, 0, {0, -100}},   // look up 0.25 rad
      {12, E::Move, 0, {0, -10000}}, // far up: stops short of the pole
      {13, E::LookUp},
      {13, E::Move, 0, {300, 0}}, // not looking: no turn
      {14, E::KeyDown, GLFW_KEY_S},
      {15, E::KeyUp, GLFW_KEY_S}, // one frame back along the view
      {15, E::KeyDown, GLFW_KEY_T},
      {18, E::KeyUp, GLFW_KEY_T}, // held three frames: one switch
      {16, E::Scroll, 0, {1, 0}}, // speed x 1.25
      {18, E::KeyDown, GLFW_KEY_ESCAPE},
      {20, E::KeyDown, GLFW_KEY_W},
      {20, E::KeyDown, GLFW_KEY_V}, // the overlay has the keyboard
      {21, E::KeyUp, GLFW_KEY_W},
      {21, E::LookDown},
      {22, E::Move, 0, {100, 0}}, // pressed over the overlay: its drag
  };
  // Step by step: after frame 4, 9, 10, 11, 12, 13, 14.
  auto after = [&](uint64_t frames) {
    Session copy = s;
    play(copy, events, frames, kDt);
    return copy;
  };
  EXPECT_NEAR(glm::length(after(5).fly.position - (start + glm::vec3(0, 0, -1.0f))), 0.0f, 1e-5f);
  EXPECT_NEAR(glm::length(after(10).fly.position - (start + glm::vec3(1.0f, 1.0f, -1.0f))), 0.0f, 1e-5f);
  Session turned = after(11);
  EXPECT_NEAR(turned.fly.yaw, 200 * kLookRadiansPerPixel, 1e-6f);
  EXPECT_EQ(turned.fly.pitch, 0.0f);
  EXPECT_TRUE(turned.looking);
  EXPECT_NEAR(after(12).fly.pitch, 100 * kLookRadiansPerPixel, 1e-6f);
  EXPECT_FLOAT_EQ(after(13).fly.pitch, kPitchLimitRadians);
  Session released = after(14);
  EXPECT_FALSE(released.looking);
  EXPECT_NEAR(released.fly.yaw, 200 * kLookRadiansPerPixel, 1e-6f);
  Session back = after(15);
  glm::vec3 expectedBack = released.fly.position - forwardOf(released.fly) * (2.0f * kDt);
  EXPECT_NEAR(glm::length(back.fly.position - expectedBack), 0.0f, 1e-5f);

  play(s, events, 24, kDt);
  const std::vector<std::pair<uint64_t, Action>> actions = {
      {15, Action::Transparency}, {18, Action::Close}, {19, Action::Surfels}};
  EXPECT_EQ(s.actions, actions); // T once while held; V not while the overlay had the keyboard
  EXPECT_FALSE(s.ui.config.transparency);
  EXPECT_FALSE(s.ui.config.drawSurfels);
  EXPECT_TRUE(s.script.empty()); // consumed
  EXPECT_NEAR(s.fly.speed, 2.0f * kSpeedStepPerNotch, 1e-6f);
  EXPECT_NEAR(glm::length(s.fly.position - back.fly.position), 0.0f, 1e-5f); // W under the overlay: no move
  EXPECT_FALSE(s.looking);                                                   // the press began over the overlay
  EXPECT_NEAR(s.fly.yaw, 200 * kLookRadiansPerPixel, 1e-6f);
}
