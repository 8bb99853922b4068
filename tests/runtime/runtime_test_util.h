// Shared by the runtime tests: the size of their views, a small blob .mrg baked once per test
// process, and the View of a scene from its automatic camera.
#pragma once

#include <cstdlib>
#include <filesystem>

#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/runtime/scene.h"
#include "test_support.h"

namespace mirage::test {

// The views the runtime tests draw: small, as lavapipe renders them on the CPU.
inline constexpr uint32_t kViewWidth = 64, kViewHeight = 48;

// gen:blob:3 baked with the default build and saved as a .mrg (one per process).
inline const std::filesystem::path& blobMrg() {
  static const std::filesystem::path path = [] {
    std::filesystem::path p = tempDir("runtime_blob_mrg") / "blob.mrg";
    auto asset = lod::bakeLodAsset(io::generateScene("blob", 1, 3).value(), {});
    if (!asset || !lod::saveLodAsset(p.string(), *asset).ok()) std::abort();
    return p;
  }();
  return path;
}

// A width x height View of `scene` from its automatic camera.
inline runtime::View viewOf(const runtime::Scene& scene, uint32_t width, uint32_t height) {
  runtime::View v;
  v.width = width;
  v.height = height;
  v.camera = render::autoCamera(scene.bounds(), float(width) / float(height));
  return v;
}

} // namespace mirage::test
