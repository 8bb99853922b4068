#pragma once
// Vulkan instance + device: device choice, the features Mirage uses, validation-layer capture.
#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/vk.h"

namespace mirage::gpu {

// What Mirage asks of a device, read once when the device is chosen.
struct DeviceCapabilities {
  std::string name;
  std::string driver; // driver name and info string
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  uint32_t apiVersion = 0;
  bool meshShader = false;         // VK_EXT_mesh_shader mesh + task stages
  bool geometryShader = false;     // the geometry stage (core feature geometryShader)
  bool rayTracingPipeline = false; // VK_KHR_ray_tracing_pipeline (with acceleration structures)
  bool rayQuery = false;           // VK_KHR_ray_query
  bool accelerationStructure = false;
  bool int64BufferAtomics = false;       // shaderBufferInt64Atomics: the 64-bit visibility buffer
  bool int64SharedAtomics = false;       // shaderSharedInt64Atomics: the compute raster's tile queue
  bool int64ImageAtomics = false;        // VK_EXT_shader_image_atomic_int64
  bool fragmentStoresAndAtomics = false; // storage writes from fragment shaders (hybrid raster)
  bool floatBufferAtomicAdd = false;     // VK_EXT_shader_atomic_float shaderBufferFloat32AtomicAdd (particle splat)
  bool floatSharedAtomicAdd = false;     // VK_EXT_shader_atomic_float shaderSharedFloat32AtomicAdd (binned splat)
  bool pipelineStatistics = false;
  uint32_t maxMultiviewViews = 0;
  bool multiview = false;           // VK_KHR_multiview (core 1.1 feature): one pass renders several views
  bool multiviewMeshShader = false; // multiview with mesh shaders (VK_EXT_mesh_shader's multiviewMeshShader)
  uint32_t subgroupSize = 0;
  bool timestamps = false;        // timestamps on the graphics/compute queue
  float timestampPeriodNs = 0.0f; // nanoseconds per timestamp tick
  uint64_t maxStorageBufferRange = 0;
  uint64_t deviceLocalBytes = 0;
};

struct DeviceInfo {
  uint32_t index = 0;
  DeviceCapabilities caps;
};

struct ContextOptions {
  std::string device;      // name substring or index; empty: MIRAGE_DEVICE, then discrete > integrated > CPU
  bool validation = false; // also on when MIRAGE_VALIDATION=1
  bool synchronizationValidation = true; // with validation: VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION
  // Presentation (the viewer): the instance extensions the window system asks for
  // (glfwGetRequiredInstanceExtensions) and VK_KHR_swapchain on the device. Headless: both empty.
  std::vector<std::string> instanceExtensions;
  bool swapchain = false;
};

class Context {
public:
  static Result<std::unique_ptr<Context>> create(const ContextOptions& options = {});
  // Devices visible to the loader, with their capabilities (no device is created).
  static Result<std::vector<DeviceInfo>> enumerateDevices();
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physicalDevice() const { return physical_; }
  VkDevice device() const { return device_; }
  VkQueue queue() const { return queue_; }
  uint32_t queueFamily() const { return queueFamily_; }
  // A queue of a transfer-only family (the copy engines; NVIDIA has one, lavapipe none): copies
  // there run beside the graphics queue's work. Null, and the family UINT32_MAX, where missing.
  VkQueue transferQueue() const { return transferQueue_; }
  uint32_t transferFamily() const { return transferFamily_; }
  // A one-shot command buffer for the transfer queue (or queue() where there is none), begun; ended
  // and submitted by submitTransfer (`fence`, unsignalled, signals), given back by freeOneShot.
  VkCommandBuffer beginTransferCommands();
  void submitTransfer(VkCommandBuffer cmd, VkFence fence);
  const DeviceCapabilities& caps() const { return caps_; }
  const VkPhysicalDeviceProperties& properties() const { return properties_; }
  Allocator& allocator() { return *allocator_; }
  bool validationEnabled() const { return messenger_ != VK_NULL_HANDLE; }
  // MIRAGE_PIPELINE_STATS set and supported: pipelines report the driver's statistics on creation.
  bool pipelineStatistics() const { return pipelineStatistics_; }

  // Validation warnings and errors since creation (tests fail when this is non-zero).
  uint32_t validationIssues() const { return validationIssues_.load(); }
  const std::vector<std::string>& validationMessages() const { return validationMessages_; }
  void recordValidationMessage(std::string message);

  // One-shot command buffers may be recorded and submitted from several threads at once (the lanes
  // of a ray backend, one per thread): each thread records from its own command pool and the
  // submissions to the queue are serialized here. Other users of queue() submit from one thread
  // while no lane runs.
  // Run `record` in a one-shot command buffer on the queue and wait for it.
  template <class F> void submitAndWait(F&& record) {
    VkCommandBuffer cmd = beginOneShot();
    record(cmd);
    endOneShotAndWait(cmd);
  }
  VkCommandBuffer beginOneShot();
  void endOneShotAndWait(VkCommandBuffer cmd);
  // A one-shot command buffer ended and submitted without waiting: `fence` (unsignalled) signals
  // when it completed; then freeOneShot(cmd) gives it back.
  void endOneShotAndSubmit(VkCommandBuffer cmd, VkFence fence);
  void freeOneShot(VkCommandBuffer cmd);

  void setDebugName(VkObjectType type, uint64_t handle, const char* name) const;

private:
  Context() = default;

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queueFamily_ = 0;
  VkQueue transferQueue_ = VK_NULL_HANDLE;
  uint32_t transferFamily_ = UINT32_MAX;
  // One-shot command buffers: a pool per recording thread, the pool of each buffer out, the queue.
  struct CommandPool {
    std::thread::id thread;
    uint32_t family = 0;
    VkCommandPool pool = VK_NULL_HANDLE;
  };
  VkCommandBuffer beginCommands(uint32_t family);
  void endAndSubmit(VkQueue queue, VkCommandBuffer cmd, VkFence fence); // ends `cmd`, submits it alone
  std::mutex oneShotMutex_;
  std::vector<CommandPool> commandPools_;
  std::unordered_map<VkCommandBuffer, VkCommandPool> oneShotPool_;
  std::unique_ptr<Allocator> allocator_;
  VkPhysicalDeviceProperties properties_{};
  DeviceCapabilities caps_;
  bool pipelineStatistics_ = false;
  std::atomic<uint32_t> validationIssues_{0};
  std::vector<std::string> validationMessages_;
};

const char* deviceTypeName(VkPhysicalDeviceType type);

} // namespace mirage::gpu
