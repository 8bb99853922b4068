#pragma once
// The viewer's fly camera as plain data and functions (no window): WASD/QE move along the view's
// right / up / forward axes, mouse motion turns it (yaw around world +y, pitch clamped short of the
// poles), the scroll wheel scales the speed. Converts to and from render::Camera, so `--camera`,
// `--path` and the frame-the-scene key share one camera.
#include <glm/glm.hpp>

#include "mirage/core/scene.h"
#include "mirage/render/camera.h"

namespace mirage::viewer {

inline constexpr float kLookRadiansPerPixel = 0.0025f; // mouse look sensitivity
inline constexpr float kPitchLimitRadians = 1.55f;     // just under 90 degrees: up never meets forward
inline constexpr float kSpeedStepPerNotch = 1.25f;     // speed factor per scroll notch
inline constexpr float kMinSpeed = 1e-4f, kMaxSpeed = 1e6f;

struct FlyCamera {
  glm::vec3 position{0.0f, 0.0f, 5.0f};
  float yaw = 0.0f;   // radians around +y; 0 looks along -z, positive turns right
  float pitch = 0.0f; // radians; positive looks up
  float fovYDegrees = 60.0f;
  float speed = 1.0f; // world units per second
  float focus = 1.0f; // distance to the target written by toCamera (keeps --camera strings readable)
};

// One frame of input: move axes in -1..1 (x right, y up, z forward), mouse motion in pixels
// (screen y down) while looking, scroll notches, seconds elapsed.
struct FlyInput {
  glm::vec3 move{0.0f};
  glm::vec2 look{0.0f};
  float scroll = 0.0f;
  float seconds = 0.0f;
};

// The raw input of one frame as the window reports it, and whether the overlay holds the keyboard
// or the mouse (ImGui's WantCaptureKeyboard / WantCaptureMouse).
struct InputState {
  bool forward = false, left = false, back = false, right = false, down = false, up = false; // W A S D Q E
  bool lookButton = false;                                                                   // right mouse button held
  glm::vec2 mouseDelta{0.0f}; // pixels since the last frame
  float scroll = 0.0f;        // notches since the last frame
  bool overlayKeyboard = false, overlayMouse = false;
};
inline constexpr float kMaxStepSeconds = 0.25f; // a stall (loading, a breakpoint) does not fling the camera

// Looking starts with a look-button press outside the overlay and lasts while the button is held
// (the cursor is hidden and unbounded meanwhile, so a turn never stops at the window's edge).
bool nextLooking(bool looking, const InputState& input);
// The fly input of a frame: keys unless the overlay has the keyboard, mouse look while `looking`,
// the wheel unless the overlay has the mouse, at most kMaxStepSeconds.
FlyInput flyInput(const InputState& input, bool looking, float seconds);

glm::vec3 forwardOf(const FlyCamera& camera);
glm::vec3 rightOf(const FlyCamera& camera);
// The move axes of WASD (forward/left/back/right) and Q/E (down/up).
glm::vec3 moveAxes(bool w, bool a, bool s, bool d, bool q, bool e);
void update(FlyCamera& camera, const FlyInput& input);

// Looks along camera's eye -> target (up assumed +y), fov kept, focus = eye-target distance;
// speed from `bounds`: crossing the scene's radius takes two seconds.
FlyCamera fromCamera(const render::Camera& camera, const Bounds& bounds);
// eye = position, target = position + focus * forward, up +y; clip planes left to the renderer.
render::Camera toCamera(const FlyCamera& camera);
// The frame-the-scene key: render::autoCamera of the bounds at this aspect, as a fly camera.
FlyCamera frameScene(const Bounds& bounds, float aspect, float fovYDegrees = 60.0f);

} // namespace mirage::viewer
