#pragma once
// The viewer's keys as one table (docs/viewer.md "Keys" lists the same): the loop asks which action
// a pressed key means, the overlay prints the table, and the tests check it without a window. The
// fly keys (W A S D Q E, held) and the mouse are read in the loop (fly_camera.h, InputState).
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/viewer/fly_camera.h"

#include "overlay_ui.h"
#include "polled_input.h"

namespace mirage::viewer {

enum class Action {
  Close,        // Esc
  FrameScene,   // F: render::autoCamera at the window's aspect
  CopyCamera,   // C: print the camera as a --camera string, copy it to the clipboard
  Record,       // R: start / stop recording a camera path
  Replay,       // P: replay the last path
  Screenshot,   // F12: the frame without the overlay to mirage_view_NNNN.png
  Vsync,        // V: fifo <-> the --present mode
  Transparency, // T: alpha BLEND materials on / off (cluster LOD scenes that have them)
  Surfels,      // U: the far field's surfels on / off (mixed scenes)
};

struct KeyBinding {
  int key; // GLFW key code
  Action action;
  const char* name; // as printed in the overlay
  const char* what;
};

std::span<const KeyBinding> keyBindings();
// The action of a key (GLFW code); none for keys without one (the fly keys among them).
std::optional<Action> actionOfKey(int key);
// The fly keys, GLFW codes, in InputState's order: forward, left, back, right, down, up.
std::span<const int> flyKeys();

// --keys: action keys pressed at given frames (scripted demos, tests of the loop's actions without
// a keyboard): "NAME@FRAME,..." with the names of keyBindings() (F12@2,C@3), frames counted from 0.
struct ScriptedKey {
  uint64_t frame = 0;
  Action action = Action::Close;
};
Result<std::vector<ScriptedKey>> parseKeyScript(std::string_view text);

// Actions that only flip a switch of the overlay's state: applied here (true when it changed a
// setting; a switch the scene lacks stays as it is). The others need the loop (files, window).
bool applySwitch(Action action, UiState& state);

// The viewer loop's input of one frame, in its order (tests feed scripted PolledInput through the
// same calls):
// 1. frameActions: the actions of the keys that went down (unless the overlay has the keyboard)
//    and of those scripted for `frame` (--keys; consumed from `script`), in key-table order.
std::vector<Action> frameActions(const PolledInput& input, bool overlayKeyboard, std::vector<ScriptedKey>& script,
                                 uint64_t frame);
// 2. flyStep (not while a path replays): W A S D Q E held move the fly camera along its axes, the
//    look button held (pressed outside the overlay) with mouse motion turns it, the wheel scales
//    its speed (fly_camera.h). `looking` carries over from frame to frame.
void flyStep(const PolledInput& input, bool overlayKeyboard, bool overlayMouse, float seconds, bool& looking,
             FlyCamera& fly);

} // namespace mirage::viewer
