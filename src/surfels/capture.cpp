#include "mirage/surfels/capture.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>

#include <fmt/format.h>
#include <glm/gtc/packing.hpp>
#include <tbb/parallel_for.h>

#include "mirage/gpu/commands.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/pipeline.h"
#include "capture_internal.h"

namespace mirage::surfels {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr VkFormat kPositionFormat = VK_FORMAT_R32G32B32A32_SFLOAT; // world positions need full floats
constexpr VkFormat kNormalFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

uint32_t packColor(const glm::vec4& c) {
  glm::vec4 v = glm::clamp(c, 0.0f, 1.0f) * 255.0f + 0.5f;
  return uint32_t(v.r) | uint32_t(v.g) << 8 | uint32_t(v.b) << 16 | uint32_t(v.a) << 24;
}

struct Draw {
  uint32_t firstIndex, indexCount;
  int32_t vertexOffset;
  uint32_t firstInstance, instanceCount;
  bool mirrored;
  glm::vec4 baseColor;
  uint32_t baseColorTexture; // index into the capture's texture array (0: white)
};

Unique<VkPipeline> createCapturePipeline(Context& ctx, VkPipelineLayout layout, uint32_t viewMask) {
  GraphicsPipelineDesc d;
  d.vertexShader = "surfel_capture.vert";
  d.fragmentShader = "surfel_capture.frag";
  d.layout = layout;
  d.bindings = {{0, sizeof(sio::SurfelCaptureVertex), VK_VERTEX_INPUT_RATE_VERTEX}};
  d.attributes = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(sio::SurfelCaptureVertex, position)},
                  {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(sio::SurfelCaptureVertex, normal)},
                  {2, 0, VK_FORMAT_R8G8B8A8_UNORM, offsetof(sio::SurfelCaptureVertex, color)},
                  {3, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(sio::SurfelCaptureVertex, uv)}};
  d.colorFormats = {kPositionFormat, kNormalFormat, kColorFormat};
  d.depthFormat = kDepthFormat;
  d.depthCompare = VK_COMPARE_OP_LESS; // orthographic views with forward depth
  d.viewMask = viewMask;               // one pass renders up to maxMultiviewViews directions
  return createGraphicsPipeline(ctx, d);
}

Unique<VkImageView> layerView(Context& ctx, const Image& image, VkImageAspectFlags aspect, uint32_t base,
                              uint32_t count) {
  VkImageViewCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  ci.image = image.handle();
  ci.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
  ci.format = image.format();
  ci.subresourceRange = {aspect, 0, 1, base, count};
  VkImageView view;
  MIRAGE_VK_CHECK(vkCreateImageView(ctx.device(), &ci, nullptr, &view));
  return Unique<VkImageView>(ctx.device(), view);
}

Image layeredImage(Context& ctx, uint32_t res, uint32_t layers, VkFormat format, VkImageUsageFlags usage,
                   VkImageAspectFlags aspect, const char* name) {
  VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = format;
  ci.extent = {res, res, 1};
  ci.mipLevels = 1;
  ci.arrayLayers = layers;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.usage = usage;
  return createImage(ctx, ci, aspect, name);
}

} // namespace

std::vector<glm::vec3> fibonacciDirections(uint32_t count) {
  std::vector<glm::vec3> dirs;
  const float golden = 3.14159265358979f * (3.0f - std::sqrt(5.0f));
  for (uint32_t i = 0; i < count; ++i) {
    float z = 1.0f - (2.0f * float(i) + 1.0f) / float(count);
    float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    float phi = golden * float(i);
    // y is "up" in glTF scenes: the spiral runs from top to bottom.
    dirs.push_back(glm::normalize(glm::vec3(r * std::cos(phi), z, r * std::sin(phi))));
  }
  return dirs;
}

namespace detail {

// Orthographic world -> clip for a camera on direction d around the sphere (c, r): x right, y up
// (negated: Vulkan's clip y points down), depth 0 on the camera side and 1 on the far side.
sio::SurfelView makeView(glm::vec3 d, glm::vec3 c, float r) {
  glm::vec3 upRef = std::abs(d.y) < 0.99f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  glm::vec3 right = glm::normalize(glm::cross(upRef, d));
  glm::vec3 up = glm::cross(d, right);
  glm::mat4 m(0.0f); // glm is column-major: m[column][row]
  for (int i = 0; i < 3; ++i) {
    m[i][0] = right[i] / r;
    m[i][1] = -up[i] / r;
    m[i][2] = -d[i] / (2.0f * r);
  }
  m[3][0] = -glm::dot(c, right) / r;
  m[3][1] = glm::dot(c, up) / r;
  m[3][2] = (r + glm::dot(c, d)) / (2.0f * r);
  m[3][3] = 1.0f;
  return {m, glm::vec4(d, 0.0f)};
}

std::vector<sio::SurfelView> captureViews(GBufferTexels& t, uint32_t directionCount) {
  std::vector<glm::vec3> directions = fibonacciDirections(directionCount);
  std::vector<sio::SurfelView> directionViews, views;
  for (glm::vec3 d : directions) directionViews.push_back(makeView(d, t.center, t.sphereRadius));
  t.directions.clear();
  for (uint32_t layer = 0; layer < t.layers; ++layer) {
    t.directions.insert(t.directions.end(), directions.begin(), directions.end());
    views.insert(views.end(), directionViews.begin(), directionViews.end());
  }
  return views;
}

void compactTexels(GBufferTexels& t, const float* pos4, const uint16_t* nrm, const uint32_t* col, size_t total) {
  // Valid texels, in global index order (what GBufferTexels::compactIndex relies on).
  // In parallel blocks (16 M texels at 1024² x 16 views: serial, this was most of the capture's
  // wall time on the H200 host): count per block, prefix sums, then each block fills its range.
  constexpr size_t kBlock = size_t(1) << 16;
  size_t blocks = (total + kBlock - 1) / kBlock;
  std::vector<size_t> firstOfBlock(blocks + 1, 0);
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    size_t n = 0;
    for (size_t i = b * kBlock; i < std::min(total, (b + 1) * kBlock); ++i) n += pos4[4 * i + 3] >= 0.5f;
    firstOfBlock[b + 1] = n;
  });
  for (size_t b = 0; b < blocks; ++b) firstOfBlock[b + 1] += firstOfBlock[b];
  size_t valid = firstOfBlock[blocks];
  t.ids.resize(valid);
  t.positions.resize(valid);
  t.normals.resize(valid);
  t.colors.resize(valid);
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    size_t k = firstOfBlock[b];
    for (size_t i = b * kBlock; i < std::min(total, (b + 1) * kBlock); ++i) {
      if (pos4[4 * i + 3] < 0.5f) continue;
      t.ids[k] = uint32_t(i);
      t.positions[k] = {pos4[4 * i], pos4[4 * i + 1], pos4[4 * i + 2]};
      glm::vec3 n(glm::unpackHalf1x16(nrm[4 * i]), glm::unpackHalf1x16(nrm[4 * i + 1]),
                  glm::unpackHalf1x16(nrm[4 * i + 2]));
      float len = glm::length(n);
      t.normals[k] = len > 0.0f ? n / len : glm::vec3(0, 0, 1);
      t.colors[k] = col[i];
      ++k;
    }
  });
}

// Area of each texel's surface patch, deduplicated across views: a patch dA shows up as
// dA·|cos θ_w| / texelSize² texels in every view w that sees it, so giving each texel
// texelSize² / Σ_w |cos θ_w| (over the views where the patch passes a depth check) makes the sum
// over all texels equal the visible area. Grazing sums are clamped to avoid division blow-ups.
// With depth peeling a direction counts when any of its layers holds the patch at that texel.
void computeAreas(GBufferTexels& t, const std::vector<sio::SurfelView>& views, const float* pos4) {
  uint32_t res = t.resolution;
  size_t perView = size_t(res) * res;
  uint32_t directions = t.viewCount / t.layers;
  t.areas.resize(t.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, t.size(), 4096), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i < range.end(); ++i) {
      glm::vec3 p = t.positions[i], n = t.normals[i];
      uint32_t own = uint32_t(t.ids[i] / perView) % directions;
      float sum = 0.0f;
      for (uint32_t w = 0; w < directions; ++w) {
        float c = std::abs(glm::dot(n, t.directions[w]));
        if (w != own) {
          glm::vec4 clip = views[w].viewProj * glm::vec4(p, 1.0f);
          int x = int(std::floor((clip.x * 0.5f + 0.5f) * float(res)));
          int y = int(std::floor((clip.y * 0.5f + 0.5f) * float(res)));
          if (x < 0 || y < 0 || x >= int(res) || y >= int(res)) continue;
          bool seen = false;
          for (uint32_t layer = 0; layer < t.layers && !seen; ++layer) {
            const float* q = pos4 + 4 * ((layer * directions + w) * perView + size_t(y) * res + size_t(x));
            if (q[3] < 0.5f) continue;
            // Depth agreement within a texel's slope: the patch, not something in front of it.
            float depthGap = std::abs(glm::dot(glm::vec3(q[0], q[1], q[2]) - p, t.directions[w]));
            seen = depthGap <= t.texelSize * (1.5f + 1.0f / std::max(c, 0.1f));
          }
          if (!seen) continue;
        }
        sum += c;
      }
      t.areas[i] = t.texelSize * t.texelSize / std::max(sum, 0.05f);
    }
  });
  t.totalArea = 0.0;
  for (float a : t.areas) t.totalArea += a;
}

} // namespace detail

Result<GpuGBuffer> captureGBuffer(Context& ctx, const Scene& scene, const CaptureConfig& config) {
  const VkPhysicalDeviceLimits& limits = ctx.properties().limits;
  std::string source = scene.source.empty() ? "scene" : scene.source;
  if (config.resolution == 0 || config.resolution > limits.maxImageDimension2D)
    return makeError(source, fmt::format("G-buffer resolution {} is outside 1..{} (the device's largest 2D image)",
                                         config.resolution, limits.maxImageDimension2D));
  if (config.views == 0 || config.views > limits.maxImageArrayLayers)
    return makeError(source, fmt::format("view count {} is outside 1..{}", config.views, limits.maxImageArrayLayers));
  if (config.layers == 0 || config.layers > 16)
    return makeError(source, fmt::format("depth-peeling layer count {} is outside 1..16", config.layers));
  uint64_t texelCount = uint64_t(config.views) * config.layers * config.resolution * config.resolution;
  // Shaders reach the texels through device addresses (no descriptor range limit), but texel
  // indices are 32-bit.
  if (texelCount >= (1ull << 32))
    return makeError(source, fmt::format("{} views × {} layers of {}² texels exceed 2^32 texels", config.views,
                                         config.layers, config.resolution));
  Bounds world = scene.worldBounds();
  if (scene.instancedTriangleCount() == 0 || world.empty())
    return makeError(source, "scene has no triangles to sample");

  // Geometry: all meshes in one vertex and one index buffer; one instanced draw per (mesh, mirrored).
  std::vector<sio::SurfelCaptureVertex> verts;
  std::vector<uint32_t> indices;
  std::vector<Draw> draws;
  std::vector<sio::SurfelInstance> instances;
  std::map<std::pair<uint32_t, bool>, std::vector<const Instance*>> groups;
  for (const Instance& inst : scene.instances)
    if (inst.mesh < scene.meshes.size())
      groups[{inst.mesh, glm::determinant(glm::mat3(inst.transform)) < 0.0f}].push_back(&inst);
  std::vector<std::pair<uint32_t, int32_t>> meshOffsets(scene.meshes.size(), {0, -1});
  for (auto& [key, list] : groups) {
    const Mesh& m = scene.meshes[key.first];
    if (m.indices.empty()) continue;
    if (meshOffsets[key.first].second < 0) {
      meshOffsets[key.first] = {uint32_t(indices.size()), int32_t(verts.size())};
      for (size_t i = 0; i < m.positions.size(); ++i)
        verts.push_back({m.positions[i], i < m.normals.size() ? m.normals[i] : glm::vec3(0, 1, 0),
                         i < m.colors.size() ? packColor(m.colors[i]) : 0xffffffffu,
                         i < m.uv0.size() ? m.uv0[i] : glm::vec2(0.0f)});
      indices.insert(indices.end(), m.indices.begin(), m.indices.end());
    }
    glm::vec4 base(1.0f);
    uint32_t texture = 0;
    if (m.material < scene.materials.size()) {
      const Material& material = scene.materials[m.material];
      base = material.baseColorFactor;
      // Texture 0 of the capture is white; scene texture i is capture texture i + 1. Meshes
      // without UVs would read one texel of the texture: they keep the factor alone.
      if (material.baseColorTexture >= 0 && size_t(material.baseColorTexture) < scene.textures.size() && !m.uv0.empty())
        texture = uint32_t(material.baseColorTexture) + 1;
    }
    draws.push_back({meshOffsets[key.first].first, uint32_t(m.indices.size()), meshOffsets[key.first].second,
                     uint32_t(instances.size()), uint32_t(list.size()), key.second, base, texture});
    for (const Instance* inst : list)
      instances.push_back({inst->transform, glm::transpose(glm::inverse(inst->transform))});
  }

  GpuGBuffer out;
  GBufferTexels& t = out.texels;
  t.resolution = config.resolution;
  t.viewCount = config.views * config.layers;
  t.layers = config.layers;
  t.center = world.center();
  // The tightest sphere around the box centre (not the box's own sphere, which wastes up to 3× the
  // texels on a round model); a margin keeps every vertex off the clip planes.
  float maxDistance2 = 0.0f;
  for (const Instance& inst : scene.instances)
    if (inst.mesh < scene.meshes.size())
      for (glm::vec3 p : scene.meshes[inst.mesh].positions) {
        glm::vec3 d = glm::vec3(inst.transform * glm::vec4(p, 1.0f)) - t.center;
        maxDistance2 = std::max(maxDistance2, glm::dot(d, d));
      }
  t.sphereRadius = std::sqrt(maxDistance2) * 1.01f + 1e-6f;
  t.texelSize = 2.0f * t.sphereRadius / float(config.resolution);
  out.views = detail::captureViews(t, config.views);
  std::vector<sio::SurfelView> directionViews(out.views.begin(), out.views.begin() + config.views);

  Buffer vertexBuffer =
      createBufferWithData<sio::SurfelCaptureVertex>(ctx, verts, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "surfel vertices");
  Buffer indexBuffer = createBufferWithData<uint32_t>(ctx, indices, VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "surfel indices");
  Buffer instanceBuffer =
      createBufferWithData<sio::SurfelInstance>(ctx, instances, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "surfel instances");
  Buffer viewBuffer =
      createBufferWithData<sio::SurfelView>(ctx, directionViews, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "surfel views");

  // Base colour textures: a white texel first (untextured draws and the no-texture case: a
  // descriptor array cannot be empty), then the scene's textures, only when some draw uses one.
  bool anyTexture = std::any_of(draws.begin(), draws.end(), [](const Draw& d) { return d.baseColorTexture > 0; });
  std::vector<Image> textures;
  auto addTexture = [&](const uint8_t* rgba, uint32_t width, uint32_t height, bool srgb, const char* name) {
    uint32_t mips = mipLevelCount(width, height);
    VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ci.imageType = VK_IMAGE_TYPE_2D;
    ci.format = srgb ? VK_FORMAT_R8G8B8A8_SRGB : VK_FORMAT_R8G8B8A8_UNORM;
    ci.extent = {width, height, 1};
    ci.mipLevels = mips;
    ci.arrayLayers = 1;
    ci.samples = VK_SAMPLE_COUNT_1_BIT;
    ci.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    textures.push_back(createImage(ctx, ci, VK_IMAGE_ASPECT_COLOR_BIT, name));
    uploadTextureRGBA8(ctx, textures.back(), rgba, width, height, mips);
  };
  const uint8_t white[4] = {255, 255, 255, 255};
  addTexture(white, 1, 1, false, "surfel white texel");
  if (anyTexture)
    for (const Texture& tex : scene.textures) {
      if (tex.width == 0 || tex.height == 0 || tex.rgba8.size() < size_t(tex.width) * tex.height * 4)
        addTexture(white, 1, 1, false, "surfel missing texture");
      else
        addTexture(tex.rgba8.data(), tex.width, tex.height, tex.srgb, tex.name.c_str());
    }
  VkSamplerCreateInfo si{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  si.magFilter = si.minFilter = VK_FILTER_LINEAR;
  si.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
  si.addressModeU = si.addressModeV = si.addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  si.maxLod = VK_LOD_CLAMP_NONE;
  VkSampler rawSampler;
  MIRAGE_VK_CHECK(vkCreateSampler(ctx.device(), &si, nullptr, &rawSampler));
  Unique<VkSampler> sampler(ctx.device(), rawSampler);
  VkDescriptorSetLayoutBinding binding{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, uint32_t(textures.size()),
                                       VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  DescriptorSet descriptors = createDescriptorSet(ctx, {&binding, 1});
  std::vector<VkDescriptorImageInfo> infos;
  for (const Image& img : textures) infos.push_back({sampler, img.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
  writeImageDescriptors(ctx, descriptors.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, infos);

  uint32_t res = config.resolution, layers = config.views, peelLayers = config.layers;
  VkImageUsageFlags colorUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  Image images[3] = {
      layeredImage(ctx, res, layers, kPositionFormat, colorUsage, VK_IMAGE_ASPECT_COLOR_BIT, "surfel position"),
      layeredImage(ctx, res, layers, kNormalFormat, colorUsage, VK_IMAGE_ASPECT_COLOR_BIT, "surfel normal"),
      layeredImage(ctx, res, layers, kColorFormat, colorUsage, VK_IMAGE_ASPECT_COLOR_BIT, "surfel colour")};
  Image depth = layeredImage(ctx, res, layers, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                             VK_IMAGE_ASPECT_DEPTH_BIT, "surfel depth");
  const uint32_t bytesPerTexel[3] = {16, 8, 4};
  size_t perLayer = size_t(res) * res;
  size_t layerTexels = perLayer * layers; // texels of one depth-peeling layer (all directions)
  out.positions = createBuffer(ctx, layerTexels * peelLayers * 16,
                               VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                   VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                               MemoryUsage::GpuOnly, "surfel texel positions");
  Buffer readback[3];
  for (int i = 0; i < 3; ++i)
    readback[i] = createBuffer(ctx, layerTexels * peelLayers * bytesPerTexel[i], VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                               MemoryUsage::Readback, "surfel readback");

  // Multiview is core since Vulkan 1.1; devices with fewer views than directions get several passes.
  uint32_t perPass = std::max(1u, std::min(ctx.caps().maxMultiviewViews, layers));
  if (config.maxViewsPerPass) perPass = std::min(perPass, config.maxViewsPerPass);
  // lavapipe (Mesa 25) crashes when the last pass of a capture uses its maximum view count (6, 12 or
  // 18 views at 6 per pass; 16 = 6 + 6 + 4 is fine), so such splits take one view less per pass.
  if (perPass > 1 && perPass == ctx.caps().maxMultiviewViews && layers % perPass == 0) perPass -= 1;
  constexpr VkShaderStageFlags kPushStages = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  Unique<VkPipelineLayout> layout =
      createPipelineLayout(ctx, {descriptors.layout.get()}, sizeof(sio::SurfelCapturePush), kPushStages);
  std::map<uint32_t, Unique<VkPipeline>> pipelines; // by views in the pass (the last pass may have fewer)
  struct Pass {
    uint32_t base, count;
    Unique<VkImageView> views[4];
  };
  std::vector<Pass> passes;
  for (uint32_t base = 0; base < layers; base += perPass) {
    Pass p{base, std::min(perPass, layers - base), {}};
    for (int i = 0; i < 3; ++i) p.views[i] = layerView(ctx, images[i], VK_IMAGE_ASPECT_COLOR_BIT, base, p.count);
    p.views[3] = layerView(ctx, depth, VK_IMAGE_ASPECT_DEPTH_BIT, base, p.count);
    if (!pipelines.count(p.count)) pipelines[p.count] = createCapturePipeline(ctx, layout, (1u << p.count) - 1u);
    passes.push_back(std::move(p));
  }
  out.passes = uint32_t(passes.size()) * config.layers;

  GpuTimer timer(ctx, 4);
  // barriers: none on entry (uploads waited); on exit the copies into out.positions and the
  // readback buffers are complete (submitAndWait).
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    timer.cmdReset(cmd);
    uint32_t captureSlot = timer.cmdBegin(cmd, "capture");
    for (uint32_t peel = 0; peel < peelLayers; ++peel) {
      // Targets become attachments: from nothing on layer 0, after the previous layer's copies
      // (colour) and depth tests (depth) on the others.
      std::vector<ImageBarrier> toAttachment;
      for (auto& img : images)
        toAttachment.push_back({img.handle(), peel ? VK_PIPELINE_STAGE_2_COPY_BIT : VK_PIPELINE_STAGE_2_NONE,
                                peel ? VK_ACCESS_2_TRANSFER_READ_BIT : 0,
                                VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                                peel ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED,
                                VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL});
      constexpr VkPipelineStageFlags2 kDepthStages =
          VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
      constexpr VkAccessFlags2 kDepthAccess =
          VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
      toAttachment.push_back({depth.handle(), peel ? kDepthStages : VK_PIPELINE_STAGE_2_NONE, peel ? kDepthAccess : 0,
                              kDepthStages, kDepthAccess,
                              peel ? VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED,
                              VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT});
      cmdImageBarriers(cmd, toAttachment);
      // The previous layer's positions (copied into out.positions) are read by the fragment shader.
      if (peel)
        cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
      for (const Pass& p : passes) {
        VkRenderingAttachmentInfo color[3];
        for (int i = 0; i < 3; ++i) {
          color[i] = {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
          color[i].imageView = p.views[i];
          color[i].imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
          color[i].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
          color[i].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
          color[i].clearValue.color = {{0.0f, 0.0f, 0.0f, 0.0f}}; // w = 0: no surface
        }
        VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
        depthAtt.imageView = p.views[3];
        depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
        depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
        depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
        depthAtt.clearValue.depthStencil = {1.0f, 0};
        VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
        ri.renderArea = {{0, 0}, {res, res}};
        ri.viewMask = (1u << p.count) - 1u;
        ri.colorAttachmentCount = 3;
        ri.pColorAttachments = color;
        ri.pDepthAttachment = &depthAtt;
        vkCmdBeginRendering(cmd, &ri);
        cmdSetFullViewport(cmd, res, res);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines[p.count]);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &descriptors.set, 0, nullptr);
        VkDeviceSize zero = 0;
        VkBuffer vb = vertexBuffer.handle();
        vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &zero);
        vkCmdBindIndexBuffer(cmd, indexBuffer.handle(), 0, VK_INDEX_TYPE_UINT32);
        for (const Draw& d : draws) {
          sio::SurfelCapturePush push{};
          push.viewAddress = viewBuffer.address();
          push.instanceAddress = instanceBuffer.address();
          push.previousLayer = peel ? out.positions.address() + (peel - 1) * layerTexels * 16 : 0;
          push.baseColor = d.baseColor;
          push.baseView = p.base;
          push.resolution = res;
          // A quarter texel: the same surface re-rasterized lands within float noise of itself.
          push.peelEpsilon = 0.25f * t.texelSize;
          push.baseColorTexture = d.baseColorTexture;
          vkCmdPushConstants(cmd, layout, kPushStages, 0, sizeof(push), &push);
          vkCmdSetFrontFace(cmd, d.mirrored ? VK_FRONT_FACE_CLOCKWISE : VK_FRONT_FACE_COUNTER_CLOCKWISE);
          vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE); // open surfaces are sampled from both sides
          vkCmdDrawIndexed(cmd, d.indexCount, d.instanceCount, d.firstIndex, d.vertexOffset, d.firstInstance);
        }
        vkCmdEndRendering(cmd);
      }

      std::vector<ImageBarrier> toTransfer;
      for (auto& img : images)
        toTransfer.push_back({img.handle(), VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                              VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                              VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                              VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL});
      cmdImageBarriers(cmd, toTransfer);
      // This layer's copy into out.positions must not overtake the fragment reads of the
      // previous layer's range (different ranges, but one barrier keeps the hazard tracking simple).
      cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT,
                       VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
      VkBufferImageCopy region{};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, layers}; // layers land one after another
      region.imageExtent = {res, res, 1};
      region.bufferOffset = peel * layerTexels * 16;
      vkCmdCopyImageToBuffer(cmd, images[0].handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, out.positions.handle(), 1,
                             &region);
      for (int i = 1; i < 3; ++i) {
        region.bufferOffset = peel * layerTexels * bytesPerTexel[i];
        vkCmdCopyImageToBuffer(cmd, images[i].handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback[i].handle(), 1,
                               &region);
      }
    }
    timer.cmdEnd(cmd, captureSlot);

    uint32_t copySlot = timer.cmdBegin(cmd, "copy");
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_TRANSFER_READ_BIT);
    VkBufferCopy whole{0, 0, layerTexels * peelLayers * 16};
    vkCmdCopyBuffer(cmd, out.positions.handle(), readback[0].handle(), 1, &whole);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
    timer.cmdEnd(cmd, copySlot);
  });
  out.times = timer.read();

  const float* pos4 = reinterpret_cast<const float*>(readback[0].mapped());
  detail::compactTexels(t, pos4, reinterpret_cast<const uint16_t*>(readback[1].mapped()),
                        reinterpret_cast<const uint32_t*>(readback[2].mapped()), layerTexels * peelLayers);
  detail::computeAreas(t, out.views, pos4);
  return out;
}

} // namespace mirage::surfels
