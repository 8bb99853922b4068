#pragma once
// One descriptor set with its own layout and pool: what each Mirage pass binds besides buffer
// device addresses (bindless textures, a few images). Pool sizes follow from the bindings.
#include <span>

#include "mirage/gpu/vk.h"

namespace mirage::gpu {

class Context;

struct DescriptorSet {
  Unique<VkDescriptorSetLayout> layout;
  Unique<VkDescriptorPool> pool;
  VkDescriptorSet set = VK_NULL_HANDLE; // freed with the pool
};

DescriptorSet createDescriptorSet(Context& context, std::span<const VkDescriptorSetLayoutBinding> bindings);

// Writes `images` into `binding` (array elements 0..n-1) of `set`.
void writeImageDescriptors(Context& context, VkDescriptorSet set, uint32_t binding, VkDescriptorType type,
                           std::span<const VkDescriptorImageInfo> images);

} // namespace mirage::gpu
