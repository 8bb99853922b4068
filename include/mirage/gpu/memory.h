#pragma once
// Buffers and images with a simple block suballocator (VMA is not packaged in bookworm).
// Blocks of 64 MiB per memory type (buffers and images in separate blocks, so
// bufferImageGranularity never matters); first-fit free lists that coalesce on free; requests
// larger than a block get a dedicated allocation.
#include <cstdint>
#include <map>
#include <mutex>
#include <vector>

#include "mirage/gpu/vk.h"

namespace mirage::gpu {

class Context;

enum class MemoryUsage {
  GpuOnly,  // device-local
  Upload,   // host-visible, coherent: CPU writes once, GPU reads (staging, small uniforms)
  Readback, // host-visible, cached: GPU writes, CPU reads
};

struct Allocation {
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize offset = 0;
  VkDeviceSize size = 0;
  uint8_t* mapped = nullptr;   // host pointer when host-visible
  uint32_t block = UINT32_MAX; // UINT32_MAX: dedicated allocation
};

class Allocator {
public:
  explicit Allocator(Context& context);
  ~Allocator();
  Allocator(const Allocator&) = delete;
  Allocator& operator=(const Allocator&) = delete;

  Allocation allocate(const VkMemoryRequirements& req, MemoryUsage usage, bool forImage);
  void free(const Allocation& allocation);
  VkDeviceSize bytesInUse() const { return bytesInUse_; }
  VkDeviceSize bytesReserved() const { return bytesReserved_; }

private:
  struct Block {
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    uint8_t* mapped = nullptr;
    uint32_t memoryType = 0;
    bool forImage = false;
    std::map<VkDeviceSize, VkDeviceSize> freeRanges; // offset -> size
  };
  uint32_t findMemoryType(uint32_t typeBits, MemoryUsage usage) const;
  VkDeviceMemory allocateMemory(VkDeviceSize size, uint32_t type, uint8_t** mapped);

  Context& context_;
  VkPhysicalDeviceMemoryProperties props_{};
  std::vector<Block> blocks_;
  std::mutex mutex_;
  VkDeviceSize bytesInUse_ = 0;
  VkDeviceSize bytesReserved_ = 0;
  static constexpr VkDeviceSize kBlockSize = 64ull << 20;
};

class Buffer {
public:
  Buffer() = default;
  Buffer(Buffer&& o) noexcept;
  Buffer& operator=(Buffer&& o) noexcept;
  ~Buffer();

  VkBuffer handle() const { return buffer_.get(); }
  VkDeviceSize size() const { return size_; }
  VkDeviceAddress address() const { return address_; }
  uint8_t* mapped() const { return allocation_.mapped; } // host-visible buffers only
  explicit operator bool() const { return bool(buffer_); }

private:
  friend Buffer createBuffer(Context&, VkDeviceSize, VkBufferUsageFlags, MemoryUsage, const char*, bool);
  void release();
  Allocator* allocator_ = nullptr;
  Allocation allocation_;
  Unique<VkBuffer> buffer_;
  VkDeviceSize size_ = 0;
  VkDeviceAddress address_ = 0;
};

class Image {
public:
  Image() = default;
  Image(Image&& o) noexcept;
  Image& operator=(Image&& o) noexcept;
  ~Image();

  VkImage handle() const { return image_.get(); }
  VkImageView view() const { return view_.get(); }
  VkFormat format() const { return format_; }
  VkExtent3D extent() const { return extent_; }
  explicit operator bool() const { return bool(image_); }

private:
  friend Image createImage(Context&, const VkImageCreateInfo&, VkImageAspectFlags, const char*);
  void release();
  Allocator* allocator_ = nullptr;
  Allocation allocation_;
  Unique<VkImage> image_;
  Unique<VkImageView> view_;
  VkFormat format_ = VK_FORMAT_UNDEFINED;
  VkExtent3D extent_{};
};

// Every buffer gets SHADER_DEVICE_ADDRESS usage so shaders can reach it through a pointer.
Buffer createBuffer(Context& context, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUsage memory,
                    const char* name);
// withTransferQueue: shared by the queue and the transfer queue (Context::transferQueue) without
// ownership transfers (VK_SHARING_MODE_CONCURRENT), where the device has a transfer queue.
Buffer createBuffer(Context& context, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUsage memory, const char* name,
                    bool withTransferQueue);
// A 2D image (array layers allowed) with a view of all its mips and layers (none where the usage
// allows no view: copies and clears only).
Image createImage(Context& context, const VkImageCreateInfo& info, VkImageAspectFlags aspect, const char* name);
// Convenience: a 2D image of one mip and layer.
Image createImage2D(Context& context, uint32_t width, uint32_t height, VkFormat format, VkImageUsageFlags usage,
                    const char* name);

} // namespace mirage::gpu
