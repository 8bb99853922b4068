// GvsConfig <-> JSON (gvs.h), for `mirage pvs --config`.
#include <cmath>
#include <optional>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "mirage/visibility/gvs.h"

namespace mirage::vis {

namespace {

using nlohmann::json;

// One table drives parsing and writing, so the two cannot disagree on a key.
template <class F> void forEachField(GvsConfig& c, F&& f) {
  f("random_rays", c.randomRays, 1.0, 1e12);
  f("abs_edge_samples", c.absEdgeSamples, 0.0, 10000.0);
  f("abs_delta_triangle", c.absDeltaTriangle, 0.0, 1.0);
  f("abs_delta_scene", c.absDeltaScene, 0.0, 1.0);
  f("rs_delta_relative", c.rsDeltaRelative, 0.0, 1.0);
  f("rs_edge_samples", c.rsEdgeSamples, 0.0, 10000.0);
  f("rs_area_samples", c.rsAreaSamples, 0.0, 10000.0);
  f("min_new_triangles", c.minNewTriangles, 0.0, 4e9);
  f("stable_iterations", c.stableIterations, 1.0, 1e6);
  f("max_iterations", c.maxIterations, 1.0, 4e9);
  f("ray_budget", c.rayBudget, 0.0, 1e15);
  f("adaptive_border", c.adaptiveBorder, 0.0, 1.0);
  f("reverse_sampling", c.reverseSampling, 0.0, 1.0);
  f("seed", c.seed, 0.0, 1.8e19);
}

} // namespace

Result<GvsConfig> parseGvsConfig(const std::string& jsonText, const std::string& file, const GvsConfig& base) {
  json doc = json::parse(jsonText, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return makeError(file, "not valid JSON");
  if (!doc.is_object()) return makeError(file, "expected an object of GVS++ parameters");
  GvsConfig c = base;
  std::optional<Error> error;
  size_t known = 0;
  forEachField(c, [&](const char* key, auto& field, double lo, double hi) {
    if (error || !doc.contains(key)) return;
    ++known;
    const json& v = doc[key];
    using T = std::remove_reference_t<decltype(field)>;
    if constexpr (std::is_same_v<T, bool>) {
      if (!v.is_boolean())
        error = makeError(file, std::string("\"") + key + "\" must be true or false");
      else
        field = v.get<bool>();
    } else {
      bool integral = std::is_integral_v<T>;
      if (!v.is_number() || (integral && !v.is_number_integer()) || v.get<double>() < lo || v.get<double>() > hi ||
          !std::isfinite(v.get<double>()))
        error = makeError(file, std::string("\"") + key + "\" must be " + (integral ? "an integer" : "a number") +
                                    " in [" + json(lo).dump() + ", " + json(hi).dump() + "]");
      else
        field = v.get<T>();
    }
  });
  if (error) return *error;
  if (known != doc.size()) {
    GvsConfig probe;
    for (auto it = doc.begin(); it != doc.end(); ++it) {
      bool found = false;
      forEachField(probe, [&](const char* key, auto&, double, double) { found |= it.key() == key; });
      if (!found) return makeError(file, "unknown parameter \"" + it.key() + "\"");
    }
  }
  return c;
}

std::string gvsConfigToJson(const GvsConfig& config) {
  GvsConfig c = config;
  json j = json::object();
  forEachField(c, [&](const char* key, auto& field, double, double) { j[key] = field; });
  return j.dump(2);
}

} // namespace mirage::vis
