#include "ray_backend_choice.h"

#include <chrono>

#include "mirage/visibility/vulkan_backend.h"
#include "render_common.h"

namespace mirage::cli {

const ComputeVariant* findComputeVariant(const std::string& name) {
  for (const ComputeVariant& v : kComputeVariants)
    if (name == v.name) return &v;
  return nullptr;
}

Status checkRayBackendChoice(const RayBackendChoice& c) {
  if (c.backend != "auto" && c.backend != "embree" && c.backend != "vulkan" && !findComputeVariant(c.backend))
    return Error{"--backend must be auto, embree, vulkan, compute, compute-persistent, compute-bvh2, "
                 "compute-bvh2-persistent, compute-bvh2-shared-stack, compute-bvh8, compute-bvh8-persistent or "
                 "compute-bvh8-postpone"};
  if (c.geometry != "auto" && c.geometry != "flatten" && c.geometry != "instance")
    return Error{"--geometry must be auto, flatten or instance"};
  return Ok{};
}

Result<std::unique_ptr<vis::RayBackend>> openNamedRayBackend(const std::string& backend, const std::string& geometry,
                                                             bool packets, const Scene& scene, gpu::Context* context,
                                                             bool hostExploration) {
  const ComputeVariant* variant = findComputeVariant(backend);
  if (backend == "vulkan" || variant) {
    if (!context) return Error{"vulkan: no device"};
    vis::VulkanRayOptions vo;
    vo.traversal = variant ? vis::VulkanRayOptions::Traversal::Compute : vis::VulkanRayOptions::Traversal::Auto;
    if (variant) {
      vo.persistentThreads = variant->persistentThreads;
      vo.sharedStack = variant->sharedStack;
      vo.bvhWidth = variant->bvhWidth;
      vo.postponeTriangles = variant->postponeTriangles;
    }
    vo.geometry = geometry == "flatten"    ? vis::VulkanRayOptions::Geometry::Flatten
                  : geometry == "instance" ? vis::VulkanRayOptions::Geometry::Instance
                                           : vis::VulkanRayOptions::Geometry::Auto;
    vo.exploreOnDevice = !hostExploration;
    auto b = vis::createVulkanBackend(*context, scene, vo);
    if (!b) return b.error();
    return std::unique_ptr<vis::RayBackend>(std::move(*b));
  }
  vis::EmbreeOptions eo;
  eo.packets = packets;
  eo.geometry = geometry == "flatten"    ? vis::EmbreeOptions::Geometry::Flatten
                : geometry == "instance" ? vis::EmbreeOptions::Geometry::Instance
                                         : vis::EmbreeOptions::Geometry::Auto;
  return vis::createEmbreeBackend(scene, eo);
}

Result<OpenedRayBackend> openRayBackend(const RayBackendChoice& choice, const Scene& scene) {
  if (auto s = checkRayBackendChoice(choice); !s) return s.error();
  OpenedRayBackend out;
  std::string backend = choice.backend;
  if (backend != "embree") {
    auto ctx = openDevice(choice.device);
    if (ctx)
      out.context = std::move(*ctx);
    else if (backend != "auto")
      return ctx.error();
    // auto: a GPU (the Vulkan backend picks its traversal, VulkanRayOptions::Traversal::Auto); a
    // CPU driver (lavapipe) is slower than Embree.
    bool gpu = out.context && out.context->caps().type != VK_PHYSICAL_DEVICE_TYPE_CPU;
    if (backend == "auto") backend = gpu ? "vulkan" : "embree";
    if (backend == "embree") out.context.reset();
  }
  auto t0 = std::chrono::steady_clock::now();
  auto b =
      openNamedRayBackend(backend, choice.geometry, choice.packets, scene, out.context.get(), choice.hostExploration);
  if (!b) return b.error();
  out.backend = std::move(*b);
  out.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

} // namespace mirage::cli
