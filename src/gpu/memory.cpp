#include "mirage/gpu/memory.h"

#include <fmt/format.h>

#include "mirage/gpu/context.h"

namespace mirage::gpu {

namespace {
VkDeviceSize alignUp(VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; }
} // namespace

Allocator::Allocator(Context& context) : context_(context) {
  vkGetPhysicalDeviceMemoryProperties(context.physicalDevice(), &props_);
}

Allocator::~Allocator() {
  for (Block& b : blocks_)
    if (b.memory) vkFreeMemory(context_.device(), b.memory, nullptr);
}

uint32_t Allocator::findMemoryType(uint32_t typeBits, MemoryUsage usage) const {
  VkMemoryPropertyFlags required = 0, preferred = 0;
  switch (usage) {
  case MemoryUsage::GpuOnly:
    preferred = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    break;
  case MemoryUsage::Upload:
    required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    break;
  case MemoryUsage::Readback:
    required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    preferred = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
    break;
  }
  uint32_t fallback = UINT32_MAX;
  for (uint32_t i = 0; i < props_.memoryTypeCount; ++i) {
    if (!(typeBits & (1u << i))) continue;
    VkMemoryPropertyFlags f = props_.memoryTypes[i].propertyFlags;
    if ((f & required) != required) continue;
    if ((f & preferred) == preferred) return i;
    if (fallback == UINT32_MAX) fallback = i;
  }
  if (fallback == UINT32_MAX) {
    std::fprintf(stderr, "mirage: fatal: no Vulkan memory type for usage %d (type bits %x)\n", int(usage), typeBits);
    std::abort();
  }
  return fallback;
}

VkDeviceMemory Allocator::allocateMemory(VkDeviceSize size, uint32_t type, uint8_t** mapped) {
  VkMemoryAllocateFlagsInfo flags{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
  flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT; // any buffer in the block may need its address
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, &flags};
  ai.allocationSize = size;
  ai.memoryTypeIndex = type;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  MIRAGE_VK_CHECK(vkAllocateMemory(context_.device(), &ai, nullptr, &memory));
  *mapped = nullptr;
  if (props_.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) {
    void* p = nullptr;
    MIRAGE_VK_CHECK(vkMapMemory(context_.device(), memory, 0, VK_WHOLE_SIZE, 0, &p));
    *mapped = static_cast<uint8_t*>(p);
  }
  bytesReserved_ += size;
  return memory;
}

Allocation Allocator::allocate(const VkMemoryRequirements& req, MemoryUsage usage, bool forImage) {
  std::lock_guard lock(mutex_);
  uint32_t type = findMemoryType(req.memoryTypeBits, usage);
  Allocation a;
  a.size = req.size;
  bytesInUse_ += req.size;
  if (req.size > kBlockSize / 2) { // dedicated: big allocations would fragment blocks
    a.memory = allocateMemory(req.size, type, &a.mapped);
    return a;
  }
  auto tryBlock = [&](uint32_t index) -> bool {
    Block& b = blocks_[index];
    if (b.memoryType != type || b.forImage != forImage || !b.memory) return false;
    for (auto it = b.freeRanges.begin(); it != b.freeRanges.end(); ++it) {
      VkDeviceSize start = alignUp(it->first, req.alignment);
      VkDeviceSize end = it->first + it->second;
      if (start + req.size > end) continue;
      VkDeviceSize rangeStart = it->first;
      b.freeRanges.erase(it);
      if (start > rangeStart) b.freeRanges[rangeStart] = start - rangeStart;
      if (start + req.size < end) b.freeRanges[start + req.size] = end - (start + req.size);
      a.memory = b.memory;
      a.offset = start;
      a.mapped = b.mapped ? b.mapped + start : nullptr;
      a.block = index;
      return true;
    }
    return false;
  };
  for (uint32_t i = 0; i < blocks_.size(); ++i)
    if (tryBlock(i)) return a;
  Block b;
  b.size = kBlockSize;
  b.memoryType = type;
  b.forImage = forImage;
  b.memory = allocateMemory(kBlockSize, type, &b.mapped);
  b.freeRanges[0] = kBlockSize;
  blocks_.push_back(std::move(b));
  bool ok = tryBlock(uint32_t(blocks_.size() - 1));
  (void)ok;
  return a;
}

void Allocator::free(const Allocation& a) {
  if (!a.memory) return;
  std::lock_guard lock(mutex_);
  bytesInUse_ -= a.size;
  if (a.block == UINT32_MAX) {
    vkFreeMemory(context_.device(), a.memory, nullptr);
    bytesReserved_ -= a.size;
    return;
  }
  auto& ranges = blocks_[a.block].freeRanges;
  VkDeviceSize start = a.offset, size = a.size;
  auto next = ranges.lower_bound(start);
  if (next != ranges.end() && next->first == start + size) { // merge with the following free range
    size += next->second;
    next = ranges.erase(next);
  }
  if (next != ranges.begin()) { // merge with the preceding free range
    auto prev = std::prev(next);
    if (prev->first + prev->second == start) {
      prev->second += size;
      return;
    }
  }
  ranges[start] = size;
}

// ---- Buffer

Buffer::Buffer(Buffer&& o) noexcept
    : allocator_(o.allocator_), allocation_(std::exchange(o.allocation_, {})), buffer_(std::move(o.buffer_)),
      size_(o.size_), address_(o.address_) {}

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    release();
    allocator_ = o.allocator_;
    allocation_ = std::exchange(o.allocation_, {});
    buffer_ = std::move(o.buffer_);
    size_ = o.size_;
    address_ = o.address_;
  }
  return *this;
}

Buffer::~Buffer() { release(); }

void Buffer::release() {
  buffer_.reset(); // the buffer goes before its memory
  if (allocator_) allocator_->free(allocation_);
  allocation_ = {};
}

Buffer createBuffer(Context& context, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUsage memory,
                    const char* name) {
  return createBuffer(context, size, usage, memory, name, false);
}

Buffer createBuffer(Context& context, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUsage memory, const char* name,
                    bool withTransferQueue) {
  Buffer b;
  VkBufferCreateInfo ci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  ci.size = std::max<VkDeviceSize>(size, 4);
  ci.usage = usage | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
  const uint32_t families[2] = {context.queueFamily(), context.transferFamily()};
  if (withTransferQueue && context.transferQueue()) {
    ci.sharingMode = VK_SHARING_MODE_CONCURRENT;
    ci.queueFamilyIndexCount = 2;
    ci.pQueueFamilyIndices = families;
  }
  VkBuffer handle;
  MIRAGE_VK_CHECK(vkCreateBuffer(context.device(), &ci, nullptr, &handle));
  b.buffer_ = Unique<VkBuffer>(context.device(), handle);
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(context.device(), handle, &req);
  b.allocator_ = &context.allocator();
  b.allocation_ = b.allocator_->allocate(req, memory, false);
  MIRAGE_VK_CHECK(vkBindBufferMemory(context.device(), handle, b.allocation_.memory, b.allocation_.offset));
  b.size_ = size;
  VkBufferDeviceAddressInfo ai{VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO};
  ai.buffer = handle;
  b.address_ = vkGetBufferDeviceAddress(context.device(), &ai);
  if (name) context.setDebugName(VK_OBJECT_TYPE_BUFFER, uint64_t(handle), name);
  return b;
}

// ---- Image

Image::Image(Image&& o) noexcept
    : allocator_(o.allocator_), allocation_(std::exchange(o.allocation_, {})), image_(std::move(o.image_)),
      view_(std::move(o.view_)), format_(o.format_), extent_(o.extent_) {}

Image& Image::operator=(Image&& o) noexcept {
  if (this != &o) {
    release();
    allocator_ = o.allocator_;
    allocation_ = std::exchange(o.allocation_, {});
    image_ = std::move(o.image_);
    view_ = std::move(o.view_);
    format_ = o.format_;
    extent_ = o.extent_;
  }
  return *this;
}

Image::~Image() { release(); }

void Image::release() {
  view_.reset();
  image_.reset();
  if (allocator_) allocator_->free(allocation_);
  allocation_ = {};
}

Image createImage(Context& context, const VkImageCreateInfo& info, VkImageAspectFlags aspect, const char* name) {
  Image img;
  VkImage handle;
  MIRAGE_VK_CHECK(vkCreateImage(context.device(), &info, nullptr, &handle));
  img.image_ = Unique<VkImage>(context.device(), handle);
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(context.device(), handle, &req);
  img.allocator_ = &context.allocator();
  img.allocation_ = img.allocator_->allocate(req, MemoryUsage::GpuOnly, true);
  MIRAGE_VK_CHECK(vkBindImageMemory(context.device(), handle, img.allocation_.memory, img.allocation_.offset));
  img.format_ = info.format;
  img.extent_ = info.extent;
  if (name) context.setDebugName(VK_OBJECT_TYPE_IMAGE, uint64_t(handle), name);
  // A view only where the usage allows one (an image used only by copies and clears has none).
  constexpr VkImageUsageFlags kViewUsage =
      VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT |
      VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_INPUT_ATTACHMENT_BIT |
      VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT;
  if (!(info.usage & kViewUsage)) return img;
  VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vi.image = handle;
  vi.viewType = info.arrayLayers > 1 ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D;
  vi.format = info.format;
  vi.subresourceRange = {aspect, 0, info.mipLevels, 0, info.arrayLayers};
  VkImageView view;
  MIRAGE_VK_CHECK(vkCreateImageView(context.device(), &vi, nullptr, &view));
  img.view_ = Unique<VkImageView>(context.device(), view);
  return img;
}

Image createImage2D(Context& context, uint32_t width, uint32_t height, VkFormat format, VkImageUsageFlags usage,
                    const char* name) {
  VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = format;
  ci.extent = {width, height, 1};
  ci.mipLevels = 1;
  ci.arrayLayers = 1;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  ci.usage = usage;
  bool depth = format == VK_FORMAT_D32_SFLOAT || format == VK_FORMAT_D24_UNORM_S8_UINT || format == VK_FORMAT_D16_UNORM;
  return createImage(context, ci, depth ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT, name);
}

} // namespace mirage::gpu
