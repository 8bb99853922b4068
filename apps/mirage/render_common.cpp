#include "render_common.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "mirage/render/forward_renderer.h"
#include "mirage/render/render_size.h"

namespace mirage::cli {

Status checkOutputPath(const std::filesystem::path& path, const std::vector<std::string>& extensions) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  if (std::find(extensions.begin(), extensions.end(), ext) == extensions.end()) {
    std::string list;
    for (const auto& e : extensions) list += (list.empty() ? "" : ", ") + e;
    return makeError(path.string(), fmt::format("unsupported output extension (expected {})", list));
  }
  std::filesystem::path dir = path.parent_path();
  std::error_code ec;
  if (!dir.empty() && !std::filesystem::is_directory(dir, ec))
    return makeError(path.string(), "output folder does not exist");
  if (std::filesystem::is_directory(path, ec)) return makeError(path.string(), "is a folder");
  return Ok{};
}

Status parseSize(const std::string& text, uint32_t& width, uint32_t& height) {
  return render::parseRenderSize(text, width, height);
}

Result<std::unique_ptr<gpu::Context>> openDevice(const std::string& device) {
  gpu::ContextOptions options;
  options.device = device;
  return gpu::Context::create(options);
}

std::vector<gpu::PassTime> medianPassTimes(const std::vector<std::vector<gpu::PassTime>>& frames) {
  std::vector<gpu::PassTime> out;
  if (frames.empty()) return out;
  for (size_t p = 0; p < frames[0].size(); ++p) {
    std::vector<double> v;
    for (const auto& f : frames)
      if (p < f.size()) v.push_back(f[p].milliseconds);
    std::sort(v.begin(), v.end());
    out.push_back({frames[0][p].name, v[v.size() / 2]});
  }
  return out;
}

double frameMilliseconds(const std::vector<gpu::PassTime>& times) { return gpu::passMilliseconds(times, "frame"); }

} // namespace mirage::cli
