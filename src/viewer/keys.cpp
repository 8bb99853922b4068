#include "keys.h"

#include <algorithm>
#include <charconv>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <fmt/format.h>

namespace mirage::viewer {

namespace {

const KeyBinding kBindings[] = {
    {GLFW_KEY_ESCAPE, Action::Close, "Esc", "close"},
    {GLFW_KEY_F, Action::FrameScene, "F", "frame the scene"},
    {GLFW_KEY_C, Action::CopyCamera, "C", "print and copy the camera"},
    {GLFW_KEY_R, Action::Record, "R", "record a path / stop and write it"},
    {GLFW_KEY_P, Action::Replay, "P", "replay the path"},
    {GLFW_KEY_F12, Action::Screenshot, "F12", "screenshot"},
    {GLFW_KEY_V, Action::Vsync, "V", "vsync"},
    {GLFW_KEY_T, Action::Transparency, "T", "transparency"},
    {GLFW_KEY_U, Action::Surfels, "U", "surfels"},
};

const int kFlyKeys[] = {GLFW_KEY_W, GLFW_KEY_A, GLFW_KEY_S, GLFW_KEY_D, GLFW_KEY_Q, GLFW_KEY_E};

} // namespace

std::span<const KeyBinding> keyBindings() { return kBindings; }
std::span<const int> flyKeys() { return kFlyKeys; }

std::optional<Action> actionOfKey(int key) {
  for (const KeyBinding& b : kBindings)
    if (b.key == key) return b.action;
  return std::nullopt;
}

Result<std::vector<ScriptedKey>> parseKeyScript(std::string_view text) {
  std::vector<ScriptedKey> out;
  while (!text.empty()) {
    size_t comma = text.find(',');
    std::string_view item = text.substr(0, comma);
    text = comma == std::string_view::npos ? std::string_view{} : text.substr(comma + 1);
    size_t at = item.find('@');
    std::string_view name = item.substr(0, at), frame = at == std::string_view::npos ? "" : item.substr(at + 1);
    ScriptedKey key;
    auto [end, ec] = std::from_chars(frame.data(), frame.data() + frame.size(), key.frame);
    const KeyBinding* binding = nullptr;
    for (const KeyBinding& b : kBindings)
      if (name == b.name) binding = &b;
    if (!binding || frame.empty() || ec != std::errc{} || end != frame.data() + frame.size())
      return Error{fmt::format("--keys '{}': expected KEY@FRAME with KEY one of Esc F C R P F12 V T U", item)};
    key.action = binding->action;
    out.push_back(key);
  }
  return out;
}

std::vector<Action> frameActions(const PolledInput& input, bool overlayKeyboard, std::vector<ScriptedKey>& script,
                                 uint64_t frame) {
  std::vector<Action> actions;
  for (const KeyBinding& b : kBindings) {
    // A key pressed now, or scripted for this frame (consumed: a frame that draws nothing comes again).
    auto it = std::find_if(script.begin(), script.end(),
                           [&](const ScriptedKey& k) { return k.frame == frame && k.action == b.action; });
    bool scripted = it != script.end();
    if (scripted) script.erase(it);
    if (scripted || (!overlayKeyboard && input.keyPressed(b.key))) actions.push_back(b.action);
  }
  return actions;
}

void flyStep(const PolledInput& input, bool overlayKeyboard, bool overlayMouse, float seconds, bool& looking,
             FlyCamera& fly) {
  InputState in;
  in.forward = input.keyDown(kFlyKeys[0]), in.left = input.keyDown(kFlyKeys[1]), in.back = input.keyDown(kFlyKeys[2]);
  in.right = input.keyDown(kFlyKeys[3]), in.down = input.keyDown(kFlyKeys[4]), in.up = input.keyDown(kFlyKeys[5]);
  in.lookButton = input.lookButton;
  in.mouseDelta = input.mouseDelta;
  in.scroll = input.scroll;
  in.overlayKeyboard = overlayKeyboard;
  in.overlayMouse = overlayMouse;
  looking = nextLooking(looking, in);
  update(fly, flyInput(in, looking, seconds));
}

bool applySwitch(Action action, UiState& s) {
  switch (action) {
  case Action::Vsync:
    s.vsync = !s.vsync;
    return true;
  case Action::Transparency:
    if (!s.hasBlend) return false;
    s.config.transparency = !s.config.transparency;
    return true;
  case Action::Surfels:
    if (!s.mixed) return false;
    s.config.drawSurfels = !s.config.drawSurfels;
    return true;
  default:
    return false;
  }
}

} // namespace mirage::viewer
