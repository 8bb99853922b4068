#include "mirage/gpu/descriptors.h"

#include <algorithm>
#include <vector>

#include "mirage/gpu/context.h"

namespace mirage::gpu {

DescriptorSet createDescriptorSet(Context& context, std::span<const VkDescriptorSetLayoutBinding> bindings) {
  DescriptorSet d;
  VkDevice device = context.device();
  VkDescriptorSetLayoutCreateInfo li{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  li.bindingCount = uint32_t(bindings.size());
  li.pBindings = bindings.data();
  VkDescriptorSetLayout layout;
  MIRAGE_VK_CHECK(vkCreateDescriptorSetLayout(device, &li, nullptr, &layout));
  d.layout = Unique<VkDescriptorSetLayout>(device, layout);

  std::vector<VkDescriptorPoolSize> sizes; // one entry per descriptor type, counts summed
  for (const VkDescriptorSetLayoutBinding& b : bindings) {
    auto it = std::find_if(sizes.begin(), sizes.end(),
                           [&](const VkDescriptorPoolSize& s) { return s.type == b.descriptorType; });
    if (it == sizes.end())
      sizes.push_back({b.descriptorType, b.descriptorCount});
    else
      it->descriptorCount += b.descriptorCount;
  }
  VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pi.maxSets = 1;
  pi.poolSizeCount = uint32_t(sizes.size());
  pi.pPoolSizes = sizes.data();
  VkDescriptorPool pool;
  MIRAGE_VK_CHECK(vkCreateDescriptorPool(device, &pi, nullptr, &pool));
  d.pool = Unique<VkDescriptorPool>(device, pool);

  VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ai.descriptorPool = d.pool;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = d.layout.ptr();
  MIRAGE_VK_CHECK(vkAllocateDescriptorSets(device, &ai, &d.set));
  return d;
}

void writeImageDescriptors(Context& context, VkDescriptorSet set, uint32_t binding, VkDescriptorType type,
                           std::span<const VkDescriptorImageInfo> images) {
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  w.dstSet = set;
  w.dstBinding = binding;
  w.descriptorCount = uint32_t(images.size());
  w.descriptorType = type;
  w.pImageInfo = images.data();
  vkUpdateDescriptorSets(context.device(), 1, &w, 0, nullptr);
}

} // namespace mirage::gpu
