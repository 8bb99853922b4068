#include "lod_progress.h"

#include <cmath>
#include <cstdint>
#include <optional>

#include <nlohmann/json.hpp>

#include "mirage/core/image_metrics.h"
#include "mirage/io/image_io.h"

namespace mirage::cli {

namespace {

// Pixels covered in `img`: those differing from `background` (RGB).
bool covered(const ImageRGBA8& img, uint32_t x, uint32_t y, const uint8_t* background) {
  const uint8_t* p = img.at(x, y);
  return p[0] != background[0] || p[1] != background[1] || p[2] != background[2];
}

} // namespace

Status writeProgressJson(const std::string& path, const std::string& input, uint64_t bandwidthBitsPerSecond,
                         const runtime::Frame::Residency& res, std::chrono::steady_clock::time_point opened) {
  if (res.images.empty() || res.images.size() != res.frames.size() || res.frameEnds.size() != res.frames.size())
    return makeError(path, "no per-frame images to report (needs --gpu-budget on a paged .mrg)");
  const ImageRGBA8& last = res.images.back();
  // The converged image's corner is the background (the automatic camera frames the scene inside).
  const uint8_t background[3] = {last.at(0, 0)[0], last.at(0, 0)[1], last.at(0, 0)[2]};
  size_t lastCovered = 0;
  for (uint32_t y = 0; y < last.height; ++y)
    for (uint32_t x = 0; x < last.width; ++x) lastCovered += covered(last, x, y, background);
  nlohmann::json frames = nlohmann::json::array();
  std::optional<double> at30, at40;
  for (size_t i = 0; i < res.frames.size(); ++i) {
    const ImageRGBA8& img = res.images[i];
    const render::ResidencyStats& st = res.frames[i];
    double seconds = std::chrono::duration<double>(res.frameEnds[i] - opened).count();
    double db = psnr(img, last);
    size_t both = 0;
    for (uint32_t y = 0; y < img.height; ++y)
      for (uint32_t x = 0; x < img.width; ++x)
        both += covered(last, x, y, background) && covered(img, x, y, background);
    nlohmann::json f = {{"frame", i},
                        {"seconds", seconds},
                        {"bytes_received", st.bytesReceived},
                        {"bytes_read", st.bytesRead},
                        {"resident_pages", st.residentPages},
                        {"drawn_pages", st.drawnPages},
                        {"pending", st.pending},
                        {"identical", std::isinf(db)},
                        {"covered_fraction", lastCovered ? double(both) / double(lastCovered) : 1.0}};
    if (!std::isinf(db)) f["psnr_db"] = db; // identical frames have no finite PSNR
    if (!at30 && db >= 30.0) at30 = seconds;
    if (!at40 && db >= 40.0) at40 = seconds;
    frames.push_back(std::move(f));
  }
  nlohmann::json j = {{"input", input},
                      {"bandwidth_bits_per_second", bandwidthBitsPerSecond},
                      {"converged", res.converged},
                      {"first_frame_seconds", frames.front()["seconds"]},
                      {"converged_seconds", frames.back()["seconds"]},
                      {"seconds_to_30db", at30 ? nlohmann::json(*at30) : nlohmann::json(nullptr)},
                      {"seconds_to_40db", at40 ? nlohmann::json(*at40) : nlohmann::json(nullptr)},
                      {"bytes_received", res.frames.back().bytesReceived},
                      {"frames", frames}};
  std::string text = j.dump(2) + "\n";
  return io::writeFileAtomic(path, text.data(), text.size());
}

} // namespace mirage::cli
