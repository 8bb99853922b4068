#include "mirage/gpu/context.h"

#include <algorithm>
#include <cstring>
#include <mutex>

#include <fmt/format.h>

namespace mirage::gpu {

namespace {

std::mutex g_message_mutex;

bool envFlag(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::strcmp(v, "0") != 0;
}

VKAPI_ATTR VkBool32 VKAPI_CALL debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                             VkDebugUtilsMessageTypeFlagsEXT,
                                             const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  if (severity < VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) return VK_FALSE;
  auto* context = static_cast<Context*>(user);
  std::string message =
      fmt::format("{}: {}", severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT ? "error" : "warning",
                  data->pMessage ? data->pMessage : "");
  std::fprintf(stderr, "mirage: validation %s\n", message.c_str());
  context->recordValidationMessage(std::move(message));
  return VK_FALSE;
}

bool hasExtension(const std::vector<VkExtensionProperties>& list, const char* name) {
  return std::any_of(list.begin(), list.end(),
                     [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

std::vector<VkExtensionProperties> deviceExtensions(VkPhysicalDevice pd) {
  uint32_t n = 0;
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, nullptr);
  std::vector<VkExtensionProperties> list(n);
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, list.data());
  return list;
}

// The feature structs Mirage reads and enables, chained once (so query and enable use one layout).
struct FeatureChain {
  VkPhysicalDeviceFeatures2 core{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  VkPhysicalDeviceVulkan11Features v11{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES};
  VkPhysicalDeviceVulkan12Features v12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceVulkan13Features v13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  VkPhysicalDeviceMeshShaderFeaturesEXT mesh{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MESH_SHADER_FEATURES_EXT};
  VkPhysicalDeviceAccelerationStructureFeaturesKHR accel{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR};
  VkPhysicalDeviceRayTracingPipelineFeaturesKHR rtPipeline{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR};
  VkPhysicalDeviceRayQueryFeaturesKHR rayQuery{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR};
  VkPhysicalDeviceShaderImageAtomicInt64FeaturesEXT imageInt64{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_IMAGE_ATOMIC_INT64_FEATURES_EXT};
  VkPhysicalDeviceShaderAtomicFloatFeaturesEXT atomicFloat{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_ATOMIC_FLOAT_FEATURES_EXT};

  // Link only the structs whose extension the device has; the Vulkan 1.1-1.3 ones always.
  void link(bool hasMesh, bool hasAccel, bool hasRtPipeline, bool hasRayQuery, bool hasImageInt64,
            bool hasAtomicFloat) {
    void** next = &core.pNext;
    auto append = [&](auto& s) {
      *next = &s;
      next = &s.pNext;
    };
    append(v11);
    append(v12);
    append(v13);
    if (hasMesh) append(mesh);
    if (hasAccel) append(accel);
    if (hasRtPipeline) append(rtPipeline);
    if (hasRayQuery) append(rayQuery);
    if (hasImageInt64) append(imageInt64);
    if (hasAtomicFloat) append(atomicFloat);
    *next = nullptr;
  }
};

struct DeviceProbe {
  VkPhysicalDevice device = VK_NULL_HANDLE;
  DeviceCapabilities caps;
  uint32_t queueFamily = UINT32_MAX;
  uint32_t transferFamily = UINT32_MAX; // a family with transfers only (a copy engine), if any
  bool usable = false;                  // Vulkan 1.3 with dynamic rendering, synchronization2, buffer device address
  std::string whyUnusable;
  std::vector<const char*> extensions;
  bool hasMesh = false, hasAccel = false, hasRtPipeline = false, hasRayQuery = false, hasImageInt64 = false;
  bool hasAtomicFloat = false;
};

DeviceProbe probeDevice(VkPhysicalDevice pd) {
  DeviceProbe p;
  p.device = pd;
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(pd, &props);
  VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
  VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES, &driver};
  VkPhysicalDeviceMultiviewProperties multiview{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MULTIVIEW_PROPERTIES, &subgroup};
  VkPhysicalDeviceProperties2 props2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &multiview};
  vkGetPhysicalDeviceProperties2(pd, &props2);

  DeviceCapabilities& c = p.caps;
  c.name = props.deviceName;
  c.driver = fmt::format("{} {}", driver.driverName, driver.driverInfo);
  c.type = props.deviceType;
  c.apiVersion = props.apiVersion;
  c.maxMultiviewViews = multiview.maxMultiviewViewCount;
  c.subgroupSize = subgroup.subgroupSize;
  c.timestampPeriodNs = props.limits.timestampPeriod;
  c.maxStorageBufferRange = props.limits.maxStorageBufferRange;

  VkPhysicalDeviceMemoryProperties mem;
  vkGetPhysicalDeviceMemoryProperties(pd, &mem);
  for (uint32_t i = 0; i < mem.memoryHeapCount; ++i)
    if (mem.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      c.deviceLocalBytes = std::max<uint64_t>(c.deviceLocalBytes, mem.memoryHeaps[i].size);

  uint32_t nq = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, nullptr);
  std::vector<VkQueueFamilyProperties> families(nq);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, families.data());
  for (uint32_t i = 0; i < nq; ++i) {
    if ((families[i].queueFlags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) ==
        (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) {
      p.queueFamily = i;
      c.timestamps = families[i].timestampValidBits > 0 && props.limits.timestampPeriod > 0.0f;
      break;
    }
  }
  for (uint32_t i = 0; i < nq; ++i)
    if ((families[i].queueFlags & VK_QUEUE_TRANSFER_BIT) &&
        !(families[i].queueFlags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) && families[i].queueCount > 0) {
      p.transferFamily = i;
      break;
    }

  auto exts = deviceExtensions(pd);
  p.hasMesh = hasExtension(exts, VK_EXT_MESH_SHADER_EXTENSION_NAME);
  p.hasAccel = hasExtension(exts, VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME) &&
               hasExtension(exts, VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME);
  p.hasRtPipeline = p.hasAccel && hasExtension(exts, VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME);
  p.hasRayQuery = p.hasAccel && hasExtension(exts, VK_KHR_RAY_QUERY_EXTENSION_NAME);
  p.hasImageInt64 = hasExtension(exts, VK_EXT_SHADER_IMAGE_ATOMIC_INT64_EXTENSION_NAME);
  p.hasAtomicFloat = hasExtension(exts, VK_EXT_SHADER_ATOMIC_FLOAT_EXTENSION_NAME);

  FeatureChain f;
  f.link(p.hasMesh, p.hasAccel, p.hasRtPipeline, p.hasRayQuery, p.hasImageInt64, p.hasAtomicFloat);
  vkGetPhysicalDeviceFeatures2(pd, &f.core);
  c.meshShader = p.hasMesh && f.mesh.meshShader && f.mesh.taskShader;
  c.multiview = f.v11.multiview;
  c.multiviewMeshShader = c.meshShader && c.multiview && f.mesh.multiviewMeshShader;
  c.accelerationStructure = p.hasAccel && f.accel.accelerationStructure;
  c.rayTracingPipeline = c.accelerationStructure && p.hasRtPipeline && f.rtPipeline.rayTracingPipeline;
  c.rayQuery = c.accelerationStructure && p.hasRayQuery && f.rayQuery.rayQuery;
  c.int64BufferAtomics = f.v12.shaderBufferInt64Atomics;
  c.int64SharedAtomics = f.v12.shaderSharedInt64Atomics;
  c.int64ImageAtomics = p.hasImageInt64 && f.imageInt64.shaderImageInt64Atomics;
  c.pipelineStatistics = f.core.features.pipelineStatisticsQuery;
  c.fragmentStoresAndAtomics = f.core.features.fragmentStoresAndAtomics;
  c.geometryShader = f.core.features.geometryShader;
  c.floatBufferAtomicAdd = p.hasAtomicFloat && f.atomicFloat.shaderBufferFloat32AtomicAdd;
  c.floatSharedAtomicAdd = p.hasAtomicFloat && f.atomicFloat.shaderSharedFloat32AtomicAdd;

  if (VK_API_VERSION_MINOR(props.apiVersion) < 3 && VK_API_VERSION_MAJOR(props.apiVersion) == 1)
    p.whyUnusable = "Vulkan 1.3 required";
  else if (p.queueFamily == UINT32_MAX)
    p.whyUnusable = "no graphics+compute queue";
  else if (!f.v13.dynamicRendering || !f.v13.synchronization2 || !f.v12.bufferDeviceAddress || !f.v12.scalarBlockLayout)
    p.whyUnusable = "dynamicRendering, synchronization2, bufferDeviceAddress and scalarBlockLayout required";
  p.usable = p.whyUnusable.empty();

  if (c.meshShader) p.extensions.push_back(VK_EXT_MESH_SHADER_EXTENSION_NAME);
  if (c.accelerationStructure) {
    p.extensions.push_back(VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME);
    p.extensions.push_back(VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME);
  }
  if (c.rayTracingPipeline) p.extensions.push_back(VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME);
  if (c.rayQuery) p.extensions.push_back(VK_KHR_RAY_QUERY_EXTENSION_NAME);
  if (c.int64ImageAtomics) p.extensions.push_back(VK_EXT_SHADER_IMAGE_ATOMIC_INT64_EXTENSION_NAME);
  if (c.floatBufferAtomicAdd || c.floatSharedAtomicAdd)
    p.extensions.push_back(VK_EXT_SHADER_ATOMIC_FLOAT_EXTENSION_NAME);
  return p;
}

Result<VkInstance> createInstance(bool validation, bool syncValidation, const std::vector<std::string>& extra,
                                  bool& validationActive) {
  static std::once_flag volk_once;
  static VkResult volk_result = VK_SUCCESS;
  std::call_once(volk_once, [] { volk_result = volkInitialize(); });
  if (volk_result != VK_SUCCESS)
    return Error{"vulkan: no Vulkan loader found (install libvulkan1 and a driver, e.g. mesa-vulkan-drivers)"};

  std::vector<const char*> layers, extensions;
  validationActive = false;
  if (validation) {
    uint32_t n = 0;
    vkEnumerateInstanceLayerProperties(&n, nullptr);
    std::vector<VkLayerProperties> available(n);
    vkEnumerateInstanceLayerProperties(&n, available.data());
    bool found = std::any_of(available.begin(), available.end(), [](const VkLayerProperties& l) {
      return std::strcmp(l.layerName, "VK_LAYER_KHRONOS_validation") == 0;
    });
    if (!found)
      return Error{"vulkan: validation requested but VK_LAYER_KHRONOS_validation is not installed (apt-get install "
                   "vulkan-validationlayers)"};
    layers.push_back("VK_LAYER_KHRONOS_validation");
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    validationActive = true;
  } else {
    // Debug names help external tools; take the extension when the loader offers it.
    uint32_t n = 0;
    vkEnumerateInstanceExtensionProperties(nullptr, &n, nullptr);
    std::vector<VkExtensionProperties> available(n);
    vkEnumerateInstanceExtensionProperties(nullptr, &n, available.data());
    if (hasExtension(available, VK_EXT_DEBUG_UTILS_EXTENSION_NAME))
      extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }

  for (const std::string& name : extra)
    if (std::none_of(extensions.begin(), extensions.end(), [&](const char* e) { return name == e; }))
      extensions.push_back(name.c_str());

  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "mirage";
  app.pEngineName = "mirage";
  app.apiVersion = VK_API_VERSION_1_3;
  VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ci.pApplicationInfo = &app;
  ci.enabledLayerCount = uint32_t(layers.size());
  ci.ppEnabledLayerNames = layers.data();
  ci.enabledExtensionCount = uint32_t(extensions.size());
  ci.ppEnabledExtensionNames = extensions.data();
  VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
  VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  features.enabledValidationFeatureCount = 1;
  features.pEnabledValidationFeatures = enables;
  if (validation && syncValidation) ci.pNext = &features;

  VkInstance instance = VK_NULL_HANDLE;
  VkResult r = vkCreateInstance(&ci, nullptr, &instance);
  if (r != VK_SUCCESS) return Error{fmt::format("vulkan: vkCreateInstance failed ({})", toString(r))};
  volkLoadInstanceOnly(instance);
  return instance;
}

std::vector<VkPhysicalDevice> physicalDevices(VkInstance instance) {
  uint32_t n = 0;
  vkEnumeratePhysicalDevices(instance, &n, nullptr);
  std::vector<VkPhysicalDevice> list(n);
  vkEnumeratePhysicalDevices(instance, &n, list.data());
  return list;
}

int typeRank(VkPhysicalDeviceType t) {
  switch (t) {
  case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
    return 4;
  case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
    return 3;
  case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
    return 2;
  case VK_PHYSICAL_DEVICE_TYPE_CPU:
    return 1;
  default:
    return 0;
  }
}

} // namespace

const char* deviceTypeName(VkPhysicalDeviceType type) {
  switch (type) {
  case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
    return "discrete";
  case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
    return "integrated";
  case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
    return "virtual";
  case VK_PHYSICAL_DEVICE_TYPE_CPU:
    return "cpu";
  default:
    return "other";
  }
}

Result<std::vector<DeviceInfo>> Context::enumerateDevices() {
  bool active = false;
  auto instance = createInstance(false, false, {}, active);
  if (!instance) return instance.error();
  std::vector<DeviceInfo> out;
  auto list = physicalDevices(*instance);
  for (uint32_t i = 0; i < list.size(); ++i) out.push_back({i, probeDevice(list[i]).caps});
  vkDestroyInstance(*instance, nullptr);
  return out;
}

void Context::recordValidationMessage(std::string message) {
  std::lock_guard lock(g_message_mutex);
  validationIssues_++;
  validationMessages_.push_back(std::move(message));
}

Result<std::unique_ptr<Context>> Context::create(const ContextOptions& options) {
  std::unique_ptr<Context> ctx(new Context());
  bool validation = options.validation || envFlag("MIRAGE_VALIDATION");
  bool active = false;
  auto instance = createInstance(validation, options.synchronizationValidation, options.instanceExtensions, active);
  if (!instance) return instance.error();
  ctx->instance_ = *instance;

  if (active) {
    VkDebugUtilsMessengerCreateInfoEXT mi{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    mi.messageSeverity =
        VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    mi.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    mi.pfnUserCallback = debugCallback;
    mi.pUserData = ctx.get();
    MIRAGE_VK_CHECK(vkCreateDebugUtilsMessengerEXT(ctx->instance_, &mi, nullptr, &ctx->messenger_));
  }

  // Device choice: explicit option, then MIRAGE_DEVICE, then the highest-ranked usable device.
  std::string wanted = options.device;
  if (wanted.empty())
    if (const char* env = std::getenv("MIRAGE_DEVICE")) wanted = env;
  auto list = physicalDevices(ctx->instance_);
  if (list.empty()) return Error{"vulkan: no Vulkan device found (lavapipe comes with mesa-vulkan-drivers)"};
  std::vector<DeviceProbe> probes;
  for (VkPhysicalDevice pd : list) probes.push_back(probeDevice(pd));

  int chosen = -1;
  if (!wanted.empty()) {
    bool numeric = std::all_of(wanted.begin(), wanted.end(), ::isdigit);
    for (size_t i = 0; i < probes.size(); ++i) {
      bool match = numeric ? std::stoul(wanted) == i : probes[i].caps.name.find(wanted) != std::string::npos;
      if (match) {
        chosen = int(i);
        break;
      }
    }
    if (chosen < 0) return Error{fmt::format("vulkan: no device matches '{}' (see mirage info --devices)", wanted)};
    if (!probes[chosen].usable)
      return Error{
          fmt::format("vulkan: device '{}' is unusable: {}", probes[chosen].caps.name, probes[chosen].whyUnusable)};
  } else {
    for (size_t i = 0; i < probes.size(); ++i)
      if (probes[i].usable && (chosen < 0 || typeRank(probes[i].caps.type) > typeRank(probes[chosen].caps.type)))
        chosen = int(i);
    if (chosen < 0) return Error{fmt::format("vulkan: no usable device: {}", probes[0].whyUnusable)};
  }
  DeviceProbe& p = probes[chosen];
  if (options.swapchain) {
    if (!hasExtension(deviceExtensions(p.device), VK_KHR_SWAPCHAIN_EXTENSION_NAME))
      return Error{fmt::format("vulkan: device '{}' cannot present (no VK_KHR_swapchain)", p.caps.name)};
    p.extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  }
  ctx->physical_ = p.device;
  ctx->caps_ = p.caps;
  ctx->queueFamily_ = p.queueFamily;
  vkGetPhysicalDeviceProperties(p.device, &ctx->properties_);

  // Enable exactly what Mirage uses and the device has.
  FeatureChain want;
  want.link(p.caps.meshShader, p.caps.accelerationStructure, p.caps.rayTracingPipeline, p.caps.rayQuery,
            p.caps.int64ImageAtomics, p.caps.floatBufferAtomicAdd || p.caps.floatSharedAtomicAdd);
  FeatureChain have;
  have.link(p.caps.meshShader, p.caps.accelerationStructure, p.caps.rayTracingPipeline, p.caps.rayQuery,
            p.caps.int64ImageAtomics, p.caps.floatBufferAtomicAdd || p.caps.floatSharedAtomicAdd);
  vkGetPhysicalDeviceFeatures2(p.device, &have.core);
  auto& wf = want.core.features;
  auto& hf = have.core.features;
  wf.shaderInt64 = hf.shaderInt64;
  wf.shaderInt16 = hf.shaderInt16;
  wf.fragmentStoresAndAtomics = hf.fragmentStoresAndAtomics;
  wf.vertexPipelineStoresAndAtomics = hf.vertexPipelineStoresAndAtomics;
  wf.pipelineStatisticsQuery = hf.pipelineStatisticsQuery;
  wf.multiDrawIndirect = hf.multiDrawIndirect;
  wf.drawIndirectFirstInstance = hf.drawIndirectFirstInstance;
  wf.samplerAnisotropy = hf.samplerAnisotropy;
  wf.fillModeNonSolid = hf.fillModeNonSolid;
  wf.depthClamp = hf.depthClamp;
  wf.geometryShader = hf.geometryShader;
  wf.shaderStorageImageWriteWithoutFormat = hf.shaderStorageImageWriteWithoutFormat;
  want.v11.multiview = have.v11.multiview;
  want.v11.storageBuffer16BitAccess = have.v11.storageBuffer16BitAccess;
  want.v11.shaderDrawParameters = have.v11.shaderDrawParameters;
  want.v12.bufferDeviceAddress = VK_TRUE;
  want.v12.scalarBlockLayout = VK_TRUE;
  want.v12.descriptorIndexing = have.v12.descriptorIndexing;
  want.v12.runtimeDescriptorArray = have.v12.runtimeDescriptorArray;
  want.v12.descriptorBindingPartiallyBound = have.v12.descriptorBindingPartiallyBound;
  want.v12.descriptorBindingVariableDescriptorCount = have.v12.descriptorBindingVariableDescriptorCount;
  want.v12.shaderSampledImageArrayNonUniformIndexing = have.v12.shaderSampledImageArrayNonUniformIndexing;
  want.v12.shaderBufferInt64Atomics = have.v12.shaderBufferInt64Atomics;
  want.v12.shaderSharedInt64Atomics = have.v12.shaderSharedInt64Atomics;
  want.v12.shaderInt8 = have.v12.shaderInt8;
  want.v12.storageBuffer8BitAccess = have.v12.storageBuffer8BitAccess;
  want.v12.timelineSemaphore = have.v12.timelineSemaphore;
  want.v12.hostQueryReset = have.v12.hostQueryReset;
  want.v12.drawIndirectCount = have.v12.drawIndirectCount;
  want.v12.samplerFilterMinmax = have.v12.samplerFilterMinmax;
  want.v12.vulkanMemoryModel = have.v12.vulkanMemoryModel;
  want.v12.vulkanMemoryModelDeviceScope = have.v12.vulkanMemoryModelDeviceScope;
  want.v13.dynamicRendering = VK_TRUE;
  want.v13.synchronization2 = VK_TRUE;
  want.v13.maintenance4 = have.v13.maintenance4;
  want.v13.subgroupSizeControl = have.v13.subgroupSizeControl;
  want.v13.computeFullSubgroups = have.v13.computeFullSubgroups;
  if (p.caps.meshShader) {
    want.mesh.meshShader = VK_TRUE;
    want.mesh.taskShader = VK_TRUE;
    want.mesh.multiviewMeshShader = p.caps.multiviewMeshShader ? VK_TRUE : VK_FALSE;
  }
  if (p.caps.accelerationStructure) want.accel.accelerationStructure = VK_TRUE;
  if (p.caps.rayTracingPipeline) want.rtPipeline.rayTracingPipeline = VK_TRUE;
  if (p.caps.rayQuery) want.rayQuery.rayQuery = VK_TRUE;
  if (p.caps.int64ImageAtomics) want.imageInt64.shaderImageInt64Atomics = VK_TRUE;
  if (p.caps.floatBufferAtomicAdd) want.atomicFloat.shaderBufferFloat32AtomicAdd = VK_TRUE;
  if (p.caps.floatSharedAtomicAdd) want.atomicFloat.shaderSharedFloat32AtomicAdd = VK_TRUE;

  float priority = 1.0f;
  VkDeviceQueueCreateInfo qi[2] = {{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO},
                                   {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO}};
  qi[0].queueFamilyIndex = p.queueFamily;
  qi[0].queueCount = 1;
  qi[0].pQueuePriorities = &priority;
  qi[1] = qi[0];
  qi[1].queueFamilyIndex = p.transferFamily; // the copy engine's queue, where there is one
  VkDeviceCreateInfo di{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  di.pNext = &want.core;
  di.queueCreateInfoCount = p.transferFamily == UINT32_MAX ? 1 : 2;
  di.pQueueCreateInfos = qi;
  // MIRAGE_PIPELINE_STATS=1: the driver's statistics of every pipeline (registers, shared memory,
  // ...) on stderr as it is created (pipeline.cpp), where VK_KHR_pipeline_executable_properties exists.
  VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR executableInfo{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR};
  if (envFlag("MIRAGE_PIPELINE_STATS") &&
      hasExtension(deviceExtensions(p.device), VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME)) {
    p.extensions.push_back(VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
    executableInfo.pipelineExecutableInfo = VK_TRUE;
    executableInfo.pNext = const_cast<void*>(di.pNext);
    di.pNext = &executableInfo;
    ctx->pipelineStatistics_ = true;
  }
  di.enabledExtensionCount = uint32_t(p.extensions.size());
  di.ppEnabledExtensionNames = p.extensions.data();
  VkResult r = vkCreateDevice(p.device, &di, nullptr, &ctx->device_);
  if (r != VK_SUCCESS) return Error{fmt::format("vulkan: vkCreateDevice failed on {} ({})", p.caps.name, toString(r))};
  volkLoadDevice(ctx->device_);
  vkGetDeviceQueue(ctx->device_, p.queueFamily, 0, &ctx->queue_);
  if (p.transferFamily != UINT32_MAX) {
    ctx->transferFamily_ = p.transferFamily;
    vkGetDeviceQueue(ctx->device_, p.transferFamily, 0, &ctx->transferQueue_);
  }

  ctx->allocator_ = std::make_unique<Allocator>(*ctx);
  return ctx;
}

Context::~Context() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    allocator_.reset();
    for (const CommandPool& p : commandPools_) vkDestroyCommandPool(device_, p.pool, nullptr);
    vkDestroyDevice(device_, nullptr);
  }
  if (messenger_) vkDestroyDebugUtilsMessengerEXT(instance_, messenger_, nullptr);
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

VkCommandBuffer Context::beginOneShot() { return beginCommands(queueFamily_); }

VkCommandBuffer Context::beginTransferCommands() {
  return beginCommands(transferQueue_ ? transferFamily_ : queueFamily_);
}

VkCommandBuffer Context::beginCommands(uint32_t family) {
  VkCommandBuffer cmd;
  {
    std::lock_guard lock(oneShotMutex_);
    auto mine = std::find_if(commandPools_.begin(), commandPools_.end(), [&](const CommandPool& p) {
      return p.thread == std::this_thread::get_id() && p.family == family;
    });
    if (mine == commandPools_.end()) {
      VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
      pi.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT | VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
      pi.queueFamilyIndex = family;
      VkCommandPool pool;
      MIRAGE_VK_CHECK(vkCreateCommandPool(device_, &pi, nullptr, &pool));
      mine = commandPools_.insert(commandPools_.end(), {std::this_thread::get_id(), family, pool});
    }
    VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = mine->pool;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    MIRAGE_VK_CHECK(vkAllocateCommandBuffers(device_, &ai, &cmd));
    oneShotPool_[cmd] = mine->pool;
  }
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  MIRAGE_VK_CHECK(vkBeginCommandBuffer(cmd, &bi));
  return cmd;
}

void Context::endOneShotAndWait(VkCommandBuffer cmd) {
  // A fence per call: threads wait on their own submissions only.
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence fence;
  MIRAGE_VK_CHECK(vkCreateFence(device_, &fi, nullptr, &fence));
  endOneShotAndSubmit(cmd, fence);
  MIRAGE_VK_CHECK(vkWaitForFences(device_, 1, &fence, VK_TRUE, UINT64_MAX));
  vkDestroyFence(device_, fence, nullptr);
  freeOneShot(cmd);
}

void Context::endAndSubmit(VkQueue queue, VkCommandBuffer cmd, VkFence fence) {
  MIRAGE_VK_CHECK(vkEndCommandBuffer(cmd));
  VkCommandBufferSubmitInfo cbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  cbi.commandBuffer = cmd;
  VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  si.commandBufferInfoCount = 1;
  si.pCommandBufferInfos = &cbi;
  std::lock_guard lock(oneShotMutex_);
  MIRAGE_VK_CHECK(vkQueueSubmit2(queue, 1, &si, fence));
}

void Context::endOneShotAndSubmit(VkCommandBuffer cmd, VkFence fence) { endAndSubmit(queue_, cmd, fence); }

void Context::submitTransfer(VkCommandBuffer cmd, VkFence fence) {
  endAndSubmit(transferQueue_ ? transferQueue_ : queue_, cmd, fence);
}

void Context::freeOneShot(VkCommandBuffer cmd) {
  std::lock_guard lock(oneShotMutex_);
  auto it = oneShotPool_.find(cmd);
  if (it == oneShotPool_.end()) return;
  vkFreeCommandBuffers(device_, it->second, 1, &cmd);
  oneShotPool_.erase(it);
}

void Context::setDebugName(VkObjectType type, uint64_t handle, const char* name) const {
  if (!vkSetDebugUtilsObjectNameEXT) return;
  VkDebugUtilsObjectNameInfoEXT ni{VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
  ni.objectType = type;
  ni.objectHandle = handle;
  ni.pObjectName = name;
  vkSetDebugUtilsObjectNameEXT(device_, &ni);
}

const char* toString(VkResult r) {
  switch (r) {
#define MIRAGE_CASE(x)                                                                                                 \
  case x:                                                                                                              \
    return #x;
    MIRAGE_CASE(VK_SUCCESS)
    MIRAGE_CASE(VK_NOT_READY)
    MIRAGE_CASE(VK_TIMEOUT)
    MIRAGE_CASE(VK_INCOMPLETE)
    MIRAGE_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    MIRAGE_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    MIRAGE_CASE(VK_ERROR_INITIALIZATION_FAILED)
    MIRAGE_CASE(VK_ERROR_DEVICE_LOST)
    MIRAGE_CASE(VK_ERROR_MEMORY_MAP_FAILED) MIRAGE_CASE(VK_ERROR_LAYER_NOT_PRESENT)
        MIRAGE_CASE(VK_ERROR_EXTENSION_NOT_PRESENT) MIRAGE_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
            MIRAGE_CASE(VK_ERROR_INCOMPATIBLE_DRIVER) MIRAGE_CASE(VK_ERROR_TOO_MANY_OBJECTS)
                MIRAGE_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED) MIRAGE_CASE(VK_ERROR_FRAGMENTED_POOL)
                    MIRAGE_CASE(VK_ERROR_OUT_OF_POOL_MEMORY) MIRAGE_CASE(VK_ERROR_UNKNOWN)
#undef MIRAGE_CASE
                        default : return "VkResult(?)";
  }
}

} // namespace mirage::gpu
