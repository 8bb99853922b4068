#include "mirage/render/camera.h"
#include "mirage/core/temp_files.h"
#include "mirage/core/input_text.h"
#include "mirage/shaderio/lod_error.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <string>

#include <fstream>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

namespace mirage::render {

glm::mat4 Camera::view() const { return glm::lookAtRH(eye, target, up); }

std::array<Camera, 2> stereoEyes(const Camera& camera, float ipd) {
  glm::vec3 right = glm::normalize(glm::cross(camera.target - camera.eye, camera.up));
  glm::vec3 half = right * (0.5f * ipd);
  std::array<Camera, 2> eyes{camera, camera};
  eyes[0].eye -= half;
  eyes[0].target -= half;
  eyes[1].eye += half;
  eyes[1].target += half;
  return eyes;
}

std::array<Camera, 2> stereoEyesSharedClip(const Camera& camera, float ipd, const Bounds& bounds) {
  std::array<Camera, 2> eyes = stereoEyes(camera, ipd);
  std::array<Camera, 2> clipped = {withClipPlanes(eyes[0], bounds), withClipPlanes(eyes[1], bounds)};
  for (Camera& c : clipped) {
    c.znear = std::min(clipped[0].znear, clipped[1].znear);
    c.zfar = std::max(clipped[0].zfar, clipped[1].zfar);
  }
  return clipped;
}

Result<float> stereoClipDx(const shaderio::ViewFrame& eye, float ipd) {
  const glm::vec4& xColumn = eye.proj[0];
  if (xColumn.y != 0.0f || xColumn.z != 0.0f || xColumn.w != 0.0f)
    return Error{"--stereo: the projection mixes view-space x into clip y, z or w"};
  return -ipd * xColumn.x;
}

Status validateIpd(float ipd) {
  if (!std::isfinite(ipd) || ipd < 0.0f)
    return Error{fmt::format("--ipd {} must be a finite distance >= 0 (scene units, e.g. 0.064)", ipd)};
  return Ok{};
}

glm::mat4 Camera::projection(float aspect) const {
  // Reverse-Z: swapping near and far of a [0,1]-depth projection maps near to 1 and far to 0, which
  // spreads float depth precision evenly in distance.
  glm::mat4 p = glm::perspectiveRH_ZO(glm::radians(fovYDegrees), aspect, zfar, znear);
  p[1][1] *= -1.0f; // Vulkan's clip space has y pointing down
  return p;
}

void frustumPlanes(const glm::mat4& m, glm::vec4 planes[5]) {
  auto row = [&](int r) { return glm::vec4(m[0][r], m[1][r], m[2][r], m[3][r]); };
  glm::vec4 p[5] = {row(3) + row(0), row(3) - row(0), row(3) + row(1), row(3) - row(1), row(3) - row(2)};
  for (int i = 0; i < 5; ++i) planes[i] = p[i] / glm::length(glm::vec3(p[i]));
}

shaderio::ViewFrame viewFrame(const Camera& camera, uint32_t width, uint32_t height) {
  shaderio::ViewFrame v{};
  v.view = camera.view();
  v.proj = camera.projection(float(width) / float(height));
  v.viewProj = v.proj * v.view;
  v.invViewProj = glm::inverse(v.viewProj);
  v.eye = glm::vec4(camera.eye, 1.0f);
  frustumPlanes(v.viewProj, v.planes);
  v.viewport = {float(width), float(height)};
  v.znear = camera.znear;
  v.pixelScale = shaderio::projectionScale(v.proj[1][1], float(height));
  return v;
}

namespace {

bool parseFloats(std::string_view text, float* out, int count) {
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int i = 0; i < count; ++i) {
    auto r = std::from_chars(p, end, out[i]);
    if (r.ec != std::errc() || !std::isfinite(out[i])) return false;
    p = r.ptr;
    if (i + 1 < count) {
      if (p == end || *p != ',') return false;
      ++p;
    }
  }
  return p == end;
}

} // namespace

Result<Camera> parseCamera(std::string_view text) {
  Camera c;
  bool haveEye = false, haveTarget = false;
  // Split on "key=" boundaries: values themselves contain commas.
  size_t pos = 0;
  // fmt rather than operator+: GCC 12 warns falsely (-Wrestrict) on chained string concatenation.
  // The text is echoed escaped: a camera path's strings reach here byte for byte.
  auto bad = [&](const std::string& why) { return Error{fmt::format("--camera {}: {}", quoteInput(text, 120), why)}; };
  while (pos < text.size()) {
    size_t eq = text.find('=', pos);
    if (eq == std::string_view::npos) return bad("expected key=value");
    std::string_view key = text.substr(pos, eq - pos);
    size_t next = text.size();
    for (size_t i = eq + 1; i < text.size(); ++i) {
      if (text[i] == ',' && i + 1 < text.size() && std::isalpha(static_cast<unsigned char>(text[i + 1]))) {
        next = i;
        break;
      }
    }
    std::string_view value = text.substr(eq + 1, next - eq - 1);
    float v[3];
    if (key == "eye" || key == "target" || key == "up") {
      if (!parseFloats(value, v, 3)) return bad(fmt::format("'{}' needs three numbers x,y,z", key));
      glm::vec3 vec{v[0], v[1], v[2]};
      if (key == "eye")
        c.eye = vec, haveEye = true;
      else if (key == "target")
        c.target = vec, haveTarget = true;
      else
        c.up = vec;
    } else if (key == "fov") {
      if (!parseFloats(value, v, 1) || v[0] <= 1.0f || v[0] >= 179.0f)
        return bad("fov must be a number of degrees in (1, 179)");
      c.fovYDegrees = v[0];
    } else {
      return bad(fmt::format("unknown key '{}' (eye, target, up, fov)", key));
    }
    pos = next == text.size() ? next : next + 1;
  }
  if (!haveEye || !haveTarget) return bad("eye and target are required");
  // Finite coordinates can still make an infinite distance or a zero-length up (normalize gives
  // NaN, which no comparison below would catch): each is rejected before it reaches a matrix.
  const float distance = glm::length(c.eye - c.target);
  if (distance <= 0.0f) return bad("eye and target coincide");
  if (!std::isfinite(distance)) return bad("eye and target are too far apart");
  const float upLength = glm::length(c.up);
  if (!(upLength > 0.0f) || !std::isfinite(upLength)) return bad("up must be a non-zero vector");
  if (glm::length(glm::cross(glm::normalize(c.target - c.eye), glm::normalize(c.up))) < 1e-4f)
    return bad("view direction is parallel to up");
  const glm::mat4 view = c.view();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      if (!std::isfinite(view[i][j])) return bad("coordinates too large for a view matrix");
  return c;
}

Camera autoCamera(const Bounds& bounds, float aspect, float fovYDegrees) {
  Camera c;
  c.fovYDegrees = fovYDegrees;
  glm::vec3 center = bounds.empty() ? glm::vec3(0.0f) : bounds.center();
  glm::vec3 dir = glm::normalize(glm::vec3(1.0f, 0.75f, 1.4f)); // from the target towards the eye
  glm::vec3 forward = -dir;
  glm::vec3 right = glm::normalize(glm::cross(forward, c.up));
  glm::vec3 up = glm::cross(right, forward);
  // The margin: the box fills 1/kAutoCameraMargin of the limiting axis (see camera.h).
  float tanY = std::tan(glm::radians(fovYDegrees) * 0.5f) / kAutoCameraMargin;
  float tanX = tanY * std::max(aspect, 1e-6f);
  // The tightest eye for this view direction: on each frustum side, the plane through the eye with
  // that side's fixed normal must have every box corner inside. Corner q (x right, y up, z forward
  // from the centre) is inside the right plane of an eye at (ex, ., ez) iff x - tanX·z <= ex - tanX·ez,
  // inside the left one iff -x - tanX·z <= -ex - tanX·ez; both tight at once gives ex and ez.
  // Pulling the eye straight back from there keeps every side satisfied, so the axis needing the
  // farther eye decides and the other is centred with room to spare. Fitting the eye distance
  // alone (target at the centre) lets the nearest corner fill one side of the frame while the far
  // side stays empty: a flat city then covers a third of the width.
  glm::vec3 corners[8]; // x right, y up, z forward, from the centre
  float rightMax = 0.0f, leftMax = 0.0f, upMax = 0.0f, downMax = 0.0f;
  int count = bounds.empty() ? 0 : 8;
  for (int i = 0; i < count; ++i) {
    glm::vec3 p{(i & 1) ? bounds.max.x : bounds.min.x, (i & 2) ? bounds.max.y : bounds.min.y,
                (i & 4) ? bounds.max.z : bounds.min.z};
    glm::vec3 q = p - center;
    corners[i] = {glm::dot(q, right), glm::dot(q, up), glm::dot(q, forward)};
    float x = corners[i].x, y = corners[i].y, z = corners[i].z;
    float r = x - tanX * z, l = -x - tanX * z, u = y - tanY * z, d = -y - tanY * z;
    rightMax = i == 0 ? r : std::max(rightMax, r);
    leftMax = i == 0 ? l : std::max(leftMax, l);
    upMax = i == 0 ? u : std::max(upMax, u);
    downMax = i == 0 ? d : std::max(downMax, d);
  }
  float ezX = -(rightMax + leftMax) / (2.0f * tanX), ezY = -(upMax + downMax) / (2.0f * tanY);
  float ex = 0.5f * (rightMax - leftMax), ey = 0.5f * (upMax - downMax);
  float ez = std::min(std::min(ezX, ezY), -1e-5f); // -1e-5: an empty or point-sized box
  // The slack axis: from the farther eye its corners no longer project symmetrically; centre them
  // (the sum of the extreme slopes falls as the eye moves along the axis: bisection).
  auto centre = [&](int axis, float lo, float hi) {
    for (int it = 0; it < 60; ++it) {
      float mid = 0.5f * (lo + hi), most = -1e30f, least = 1e30f;
      for (int i = 0; i < count; ++i) {
        float slope = (corners[i][axis] - mid) / (corners[i].z - ez);
        most = std::max(most, slope), least = std::min(least, slope);
      }
      (most + least > 0.0f ? lo : hi) = mid;
    }
    return 0.5f * (lo + hi);
  };
  if (count && ezX > ez) ex = centre(0, ex - 2.0f * bounds.radius(), ex + 2.0f * bounds.radius());
  if (count && ezY > ez) ey = centre(1, ey - 2.0f * bounds.radius(), ey + 2.0f * bounds.radius());
  glm::vec3 lateral = center + ex * right + ey * up;
  c.eye = lateral + ez * forward;
  c.target = lateral; // at the centre's depth: the view direction stays the 3/4 one
  return withClipPlanes(c, bounds);
}

Camera withClipPlanes(Camera c, const Bounds& bounds) {
  if (c.znear > 0.0f && c.zfar > c.znear) return c;
  glm::vec3 center = bounds.empty() ? glm::vec3(0.0f) : bounds.center();
  float radius = std::max(bounds.radius(), 1e-6f);
  float dist = glm::length(c.eye - center);
  float zfar = dist + radius * 1.01f;
  // Reverse-Z keeps precision with a small near plane, so a camera inside the bounds still works.
  float znear = std::max(dist - radius * 1.01f, zfar * 1e-5f);
  if (c.znear <= 0.0f) c.znear = znear;
  if (c.zfar <= c.znear) c.zfar = std::max(zfar, c.znear * 2.0f);
  return c;
}

namespace {

Result<glm::vec3> jsonVec3(const nlohmann::json& j, const char* key) {
  const auto& v = j.at(key);
  if (!v.is_array() || v.size() != 3) return Error{fmt::format("'{}' must be an array of three numbers", key)};
  glm::vec3 out{0.0f};
  for (int i = 0; i < 3; ++i) {
    if (!v[i].is_number()) return Error{fmt::format("'{}' must be an array of three numbers", key)};
    out[i] = v[i].get<float>();
    if (!std::isfinite(out[i])) return Error{fmt::format("'{}' is not finite", key)};
  }
  return out;
}

// One path entry: the same checks as --camera, so both spellings reject the same mistakes.
Result<Camera> cameraFromJson(const nlohmann::json& j) {
  if (j.is_string()) return parseCamera(j.get<std::string>());
  if (!j.is_object()) return Error{"expected a camera string or object"};
  for (const char* key : {"eye", "target"})
    if (!j.contains(key)) return Error{fmt::format("'{}' is required", key)};
  std::string text;
  for (const char* key : {"eye", "target", "up"}) {
    if (!j.contains(key)) continue;
    auto v = jsonVec3(j, key);
    if (!v) return v.error();
    text += fmt::format("{}{}={},{},{}", text.empty() ? "" : ",", key, v->x, v->y, v->z);
  }
  if (j.contains("fov")) {
    if (!j["fov"].is_number()) return Error{"'fov' must be a number of degrees"};
    text += fmt::format(",fov={}", j["fov"].get<float>());
  }
  auto c = parseCamera(text);
  if (!c) return c;
  for (const char* key : {"znear", "zfar"}) {
    if (!j.contains(key)) continue;
    // As a float: a double beyond float's range would become an infinite plane.
    if (!j[key].is_number() || !(j[key].get<float>() > 0.0f) || !std::isfinite(j[key].get<float>()))
      return Error{fmt::format("'{}' must be a positive finite number", key)};
  }
  c->znear = j.value("znear", 0.0f);
  c->zfar = j.value("zfar", 0.0f);
  if (c->znear > 0.0f && c->zfar > 0.0f && c->zfar <= c->znear) return Error{"'zfar' must exceed 'znear'"};
  return c;
}

} // namespace

Result<std::vector<Camera>> loadCameraPath(const std::filesystem::path& path) {
  if (std::string problem = inputFileProblem(path); !problem.empty())
    return Error{fmt::format("{}: {}", path.string(), problem)};
  std::ifstream in(path);
  if (!in) return Error{fmt::format("{}: cannot open camera path", path.string())};
  nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Error{fmt::format("{}: not valid JSON", path.string())};
  if (j.is_object() && j.contains("cameras")) j = j["cameras"];
  if (!j.is_array() || j.empty())
    return Error{fmt::format("{}: expected a non-empty array of cameras (or {{\"cameras\": [...]}})", path.string())};
  std::vector<Camera> cameras;
  for (size_t i = 0; i < j.size(); ++i) {
    Result<Camera> c = Error{""};
    try {
      c = cameraFromJson(j[i]);
    } catch (const nlohmann::json::exception&) {
      c = Error{"malformed camera"};
    }
    if (!c) return Error{fmt::format("{}: camera {}: {}", path.string(), i, c.error().message)};
    cameras.push_back(*c);
  }
  return cameras;
}

std::string formatCamera(const Camera& c) {
  // fmt's "{}" prints a float's shortest representation that reads back to the same float.
  return fmt::format("eye={},{},{},target={},{},{},up={},{},{},fov={}", c.eye.x, c.eye.y, c.eye.z, c.target.x,
                     c.target.y, c.target.z, c.up.x, c.up.y, c.up.z, c.fovYDegrees);
}

Status writeCameraPath(const std::filesystem::path& path, const std::vector<Camera>& cameras) {
  nlohmann::json j = nlohmann::json::array();
  for (const Camera& c : cameras) {
    nlohmann::json e;
    e["eye"] = {c.eye.x, c.eye.y, c.eye.z};
    e["target"] = {c.target.x, c.target.y, c.target.z};
    e["up"] = {c.up.x, c.up.y, c.up.z};
    e["fov"] = c.fovYDegrees;
    if (c.znear > 0.0f) e["znear"] = c.znear;
    if (c.zfar > 0.0f) e["zfar"] = c.zfar;
    j.push_back(std::move(e));
  }
  std::string text = j.dump(1) + "\n";
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  TempFileGuard guard(tmp.string()); // removed if a signal stops the process before the rename
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out || !out.write(text.data(), std::streamsize(text.size())) || !out.flush()) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      return Error{fmt::format("{}: cannot write camera path", path.string())};
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return Error{fmt::format("{}: cannot write camera path", path.string())};
  }
  return Ok{};
}

std::string pathFrameName(const std::string& output, size_t index) {
  std::filesystem::path p = output;
  return (p.parent_path() / fmt::format("{}_{:04}{}", p.stem().string(), index, p.extension().string())).string();
}

std::vector<Camera> orbitPath(const Bounds& bounds, float aspect, uint32_t count) {
  Camera start = autoCamera(bounds, aspect);
  start.target = bounds.empty() ? glm::vec3(0.0f) : bounds.center(); // the circle's centre
  glm::vec3 offset = start.eye - start.target;
  float radius = glm::length(glm::vec2(offset.x, offset.z));
  float angle0 = std::atan2(offset.z, offset.x);
  std::vector<Camera> out;
  for (uint32_t i = 0; i < count; ++i) {
    Camera c = start;
    float a = angle0 + 2.0f * 3.14159265f * float(i) / float(std::max(count, 1u));
    c.eye = start.target + glm::vec3(radius * std::cos(a), offset.y, radius * std::sin(a));
    out.push_back(c);
  }
  return out;
}

bool isCameraCut(const Camera& from, const Camera& to, const Bounds& bounds) {
  if (from.fovYDegrees != to.fovYDegrees || from.znear != to.znear || from.zfar != to.zfar) return true;
  float diagonal = bounds.empty() ? 0.0f : glm::length(bounds.extent());
  if (!(glm::length(to.eye - from.eye) <= kCutMoveFraction * diagonal)) return true;
  // The view direction and the right vector (roll); a degenerate camera is always a cut.
  auto axes = [](const Camera& c) {
    glm::vec3 forward = c.target - c.eye, right = glm::cross(forward, c.up);
    return std::pair(forward / glm::length(forward), right / glm::length(right));
  };
  auto [f0, r0] = axes(from);
  auto [f1, r1] = axes(to);
  float cosTurn = std::cos(glm::radians(kCutTurnDegrees));
  return !(glm::dot(f0, f1) >= cosTurn && glm::dot(r0, r1) >= cosTurn);
}

std::vector<Camera> flyPath(const Bounds& bounds, float aspect, uint32_t count) {
  (void)aspect; // the field of view is fixed; the width follows the aspect
  glm::vec3 centre = bounds.empty() ? glm::vec3(0.0f) : bounds.center();
  glm::vec3 extent = bounds.empty() ? glm::vec3(1.0f) : glm::max(bounds.extent(), glm::vec3(1e-6f));
  float across = std::max(extent.x, extent.z);
  float height = (bounds.empty() ? 0.5f : bounds.max.y) + 0.03f * across;
  float rx = 0.35f * extent.x, rz = 0.35f * extent.z;
  const float pitch = 15.0f * 3.14159265f / 180.0f; // looking down: the ground ahead, the far rows above
  std::vector<Camera> out;
  for (uint32_t i = 0; i < count; ++i) {
    float a = 2.0f * 3.14159265f * float(i) / float(std::max(count, 1u));
    Camera c;
    c.eye = glm::vec3(centre.x + rx * std::cos(a), height, centre.z + rz * std::sin(a));
    glm::vec3 ahead = glm::normalize(glm::vec3(-rx * std::sin(a), 0.0f, rz * std::cos(a))); // counter-clockwise
    c.target = c.eye + ahead * std::cos(pitch) - glm::vec3(0.0f, std::sin(pitch), 0.0f);
    c.fovYDegrees = 60.0f;
    out.push_back(c);
  }
  return out;
}

Result<std::vector<Camera>> cameraPathArgument(const std::string& argument, const Bounds& bounds, float aspect) {
  for (std::string_view kind : {"orbit:", "fly:"}) {
    if (!argument.starts_with(kind)) continue;
    uint32_t n = 0;
    std::string_view digits = std::string_view(argument).substr(kind.size());
    auto r = std::from_chars(digits.data(), digits.data() + digits.size(), n);
    if (r.ec != std::errc() || r.ptr != digits.data() + digits.size() || n < 1 || n > 100000)
      return Error{fmt::format("--path '{}': {}N needs N in 1..100000", argument, kind)};
    return kind == "orbit:" ? orbitPath(bounds, aspect, n) : flyPath(bounds, aspect, n);
  }
  return loadCameraPath(argument);
}

} // namespace mirage::render
