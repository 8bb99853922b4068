#pragma once
// Cameras: explicit eye/target/fov, or an automatic 3/4 view that frames the scene bounds.
#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/shaderio/view.h"

namespace mirage::render {

struct Camera {
  glm::vec3 eye{0.0f, 0.0f, 5.0f};
  glm::vec3 target{0.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  float fovYDegrees = 60.0f; // vertical field of view
  float znear = 0.0f;        // 0: derived from the scene bounds
  float zfar = 0.0f;         // 0: derived from the scene bounds

  glm::mat4 view() const;
  // Reverse-Z (near -> 1, far -> 0), Vulkan clip space (y down), depth in [0, 1].
  glm::mat4 projection(float aspect) const;
};

// "eye=x,y,z,target=x,y,z,fov=60[,up=x,y,z]" (keys in any order; eye and target required).
Result<Camera> parseCamera(std::string_view text);

// The automatic camera's margin: the bounding box spans 1/kAutoCameraMargin of the frame along
// its limiting axis (the other axis has room to spare).
constexpr float kAutoCameraMargin = 1.05f;

// 3/4 view from above-front-right (a fixed view direction) placed so that the bounding box's
// projection fits the frame as tightly as that direction allows: every corner inside, touching
// both sides of the limiting axis (up to the margin) and centred on the other, for any aspect
// ratio. Near/far planes bracket the bounds.
Camera autoCamera(const Bounds& bounds, float aspect, float fovYDegrees = 60.0f);

// Fill znear/zfar when zero, from the bounds seen by this camera (near plane never behind the eye).
Camera withClipPlanes(Camera camera, const Bounds& bounds);

// A camera cut: `to` is no small step from `from` in a scene with these bounds. The eye moved more
// than kCutMoveFraction of the bounds' diagonal, the view direction or the right vector turned by
// more than kCutTurnDegrees, or the field of view or clip planes changed. The GPU residency
// computes its prefetch again only on a cut from the view it last computed it for, so a camera
// moving smoothly pays it once per that much motion, not every frame (docs/render.md, "Residency").
inline constexpr float kCutMoveFraction = 0.02f; // 2 % of the scene: a viewer's step is far below
inline constexpr float kCutTurnDegrees = 10.0f;  // a sixth of a 60-degree view
bool isCameraCut(const Camera& from, const Camera& to, const Bounds& bounds);

// Default interpupillary distance for --stereo, in scene units (metres): 64 mm, a typical adult.
constexpr float kDefaultIpd = 0.064f;

// The eyes of a stereo pair: `camera` moved by -ipd/2 (left) and +ipd/2 (right) along its right
// vector (normalize(cross(target - eye, up))), eye and target alike: parallel axes, same fov, up
// and clip planes. Left first.
std::array<Camera, 2> stereoEyes(const Camera& camera, float ipd);

// An --ipd value: finite and >= 0 (0: both eyes at the camera), else an error naming the flag.
Status validateIpd(float ipd);

// The stereo eyes as the renderers draw them in one pass: stereoEyes with clip planes from
// `bounds`, both taking the union of the two eyes' clip ranges, so that they share one projection.
std::array<Camera, 2> stereoEyesSharedClip(const Camera& camera, float ipd, const Bounds& bounds);
// With that shared projection a world point's clip position in the right eye is the left eye's
// with clip x + (-ipd * P00): parallel eyes differ by the view-space translation (-ipd, 0, 0), and
// P10 = P20 = P30 = 0 for every Camera::projection. `eye` is either eye's frame; an error (checked,
// not assumed) when its projection mixes view-space x into clip y, z or w.
Result<float> stereoClipDx(const shaderio::ViewFrame& eye, float ipd);

// World-space frustum planes (Gribb-Hartmann) of a reverse-Z view-projection: clip-space inside is
// -w <= x, y <= w and z <= w (near); the far plane is left out (the camera's far bound is loose).
// Order: left, right, bottom, top, near; normalized, dot(xyz, p) + w >= 0 inside.
void frustumPlanes(const glm::mat4& viewProj, glm::vec4 planes[5]);

// What every renderer's shaders know of the camera (shaderio/view.h) for a `width` x `height`
// target. `camera` must have its clip planes set (withClipPlanes).
shaderio::ViewFrame viewFrame(const Camera& camera, uint32_t width, uint32_t height);

// The --camera string of `camera` ("eye=x,y,z,target=x,y,z,up=x,y,z,fov=deg"), numbers in their
// shortest exact form: parseCamera gives the camera back (clip planes are not part of it).
std::string formatCamera(const Camera& camera);

// A camera path for `--path`: a JSON file holding an array of cameras (or {"cameras": [...]}), each
// either a --camera string or an object {"eye": [x,y,z], "target": [x,y,z], "up": [...], "fov": deg,
// "znear": n, "zfar": f}. Errors name the file and the camera's index.
Result<std::vector<Camera>> loadCameraPath(const std::filesystem::path& path);

// Writes `cameras` as the JSON loadCameraPath reads (an array of objects; znear/zfar only when set),
// atomically (a temporary file renamed over `path`). Errors name the file.
Status writeCameraPath(const std::filesystem::path& path, const std::vector<Camera>& cameras);

// out.png, 7 -> out_0007.png: the image of camera 7 of a path (render --path, view --screenshot).
std::string pathFrameName(const std::string& output, size_t index);

// `count` cameras on a horizontal circle around the bounds' centre at autoCamera's distance and
// elevation, one full turn: a deterministic path for benchmarks and temporal tests.
std::vector<Camera> orbitPath(const Bounds& bounds, float aspect, uint32_t count);

// `count` cameras flying over the scene (a fly-through of a wide scene such as gen:many): eyes on a
// horizontal ellipse at 0.35 of the bounds' extent around its centre, 3 % of the larger horizontal
// extent above the top, each looking ahead along the ellipse (counter-clockwise) and 15° down, so a
// view holds meshes just below and rows of them out to the far side; 60° field of view. Each
// camera is a cut from the one before (benchmarks time how long the residency takes to catch up).
std::vector<Camera> flyPath(const Bounds& bounds, float aspect, uint32_t count);

// "orbit:N" -> orbitPath, "fly:N" -> flyPath, anything else a JSON file (loadCameraPath).
Result<std::vector<Camera>> cameraPathArgument(const std::string& argument, const Bounds& bounds, float aspect);

} // namespace mirage::render
