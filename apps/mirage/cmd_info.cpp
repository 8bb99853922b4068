// mirage info --devices: the Vulkan devices and the capabilities Mirage uses.
// mirage info FILE: what a scene file holds (meshes, triangles, materials, bounds).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/gpu/context.h"

namespace mirage::cli {

namespace {

nlohmann::json capsJson(const gpu::DeviceInfo& d) {
  const gpu::DeviceCapabilities& c = d.caps;
  return {{"index", d.index},
          {"name", c.name},
          {"type", gpu::deviceTypeName(c.type)},
          {"driver", c.driver},
          {"api", fmt::format("{}.{}.{}", VK_API_VERSION_MAJOR(c.apiVersion), VK_API_VERSION_MINOR(c.apiVersion),
                              VK_API_VERSION_PATCH(c.apiVersion))},
          {"mesh_shader", c.meshShader},
          {"geometry_shader", c.geometryShader},
          {"ray_tracing_pipeline", c.rayTracingPipeline},
          {"ray_query", c.rayQuery},
          {"acceleration_structure", c.accelerationStructure},
          {"int64_buffer_atomics", c.int64BufferAtomics},
          {"int64_image_atomics", c.int64ImageAtomics},
          {"float_buffer_atomic_add", c.floatBufferAtomicAdd},
          {"max_multiview_views", c.maxMultiviewViews},
          {"multiview", c.multiview},
          {"multiview_mesh_shader", c.multiviewMeshShader},
          {"subgroup_size", c.subgroupSize},
          {"timestamps", c.timestamps},
          {"timestamp_period_ns", c.timestampPeriodNs},
          {"pipeline_statistics", c.pipelineStatistics},
          {"max_storage_buffer_range", c.maxStorageBufferRange},
          {"device_local_bytes", c.deviceLocalBytes}};
}

void printDevices(bool json) {
  auto list = gpu::Context::enumerateDevices();
  if (!list) return fail(list.error());
  // Which device `auto` picks: create a context the way every command does.
  std::string chosen;
  if (auto ctx = gpu::Context::create()) chosen = (*ctx)->caps().name;
  if (json) {
    nlohmann::json arr = nlohmann::json::array();
    for (const auto& d : *list) {
      auto j = capsJson(d);
      j["default"] = d.caps.name == chosen;
      arr.push_back(j);
    }
    fmt::print("{}\n", arr.dump(2));
    return;
  }
  auto yes = [](bool b) { return b ? "yes" : "no"; };
  for (const auto& d : *list) {
    const auto& c = d.caps;
    fmt::print("[{}] {}{} ({}, Vulkan {}.{}.{}, {})\n", d.index, c.name, c.name == chosen ? "  <- default" : "",
               gpu::deviceTypeName(c.type), VK_API_VERSION_MAJOR(c.apiVersion), VK_API_VERSION_MINOR(c.apiVersion),
               VK_API_VERSION_PATCH(c.apiVersion), c.driver);
    fmt::print("    mesh shader {}  geometry shader {}  ray tracing pipeline {}  ray query {}  int64 atomics buffer {} "
               "image {}  float atomic add {}\n",
               yes(c.meshShader), yes(c.geometryShader), yes(c.rayTracingPipeline), yes(c.rayQuery),
               yes(c.int64BufferAtomics), yes(c.int64ImageAtomics), yes(c.floatBufferAtomicAdd));
    fmt::print("    multiview {} ({} views, mesh shaders {})  subgroup {}  timestamps {} ({} ns/tick)  pipeline "
               "statistics {}\n",
               yes(c.multiview), c.maxMultiviewViews, yes(c.multiviewMeshShader), c.subgroupSize, yes(c.timestamps),
               c.timestampPeriodNs, yes(c.pipelineStatistics));
    fmt::print("    max storage buffer range {} MiB  device-local memory {} MiB\n", c.maxStorageBufferRange >> 20,
               c.deviceLocalBytes >> 20);
  }
}

} // namespace

void addInfoCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("info", "Show Vulkan devices (--devices) or what a scene file holds");
  struct Options {
    bool devices = false;
    bool json = false;
    std::string file;
    std::string materials;
  };
  auto opt = std::make_shared<Options>();
  cmd->add_flag("--devices", opt->devices, "List Vulkan devices and the capabilities Mirage uses");
  cmd->add_flag("--json", opt->json, "Machine-readable output");
  cmd->add_option("file", opt->file, "Scene file (.gltf .glb .obj .ply)");
  cmd->add_option("--materials", opt->materials,
                  "Apply a material file (TOML) and list every material with where it came from")
      ->type_name("FILE.toml");
  cmd->callback([opt] {
    if (opt->devices || opt->file.empty()) return printDevices(opt->json);
    infoFile(opt->file, opt->json, opt->materials);
  });
}

} // namespace mirage::cli
