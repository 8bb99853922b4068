#pragma once
// GPU test fixture: one Vulkan context per test process with validation layers (and synchronization
// validation) on; a test fails when it caused any validation warning or error.
#include <gtest/gtest.h>

#include <memory>

#include "mirage/gpu/context.h"

namespace mirage::test {

inline gpu::Context& gpuContext() {
  static std::unique_ptr<gpu::Context> context = [] {
    gpu::ContextOptions options;
    options.validation = true;
    auto r = gpu::Context::create(options);
    if (!r) {
      std::fprintf(stderr, "cannot create a Vulkan context: %s\n", r.error().message.c_str());
      std::abort();
    }
    return std::move(r).value();
  }();
  return *context;
}

class GpuTest : public ::testing::Test {
protected:
  void SetUp() override { issuesBefore_ = gpuContext().validationIssues(); }
  void TearDown() override {
    const auto& ctx = gpuContext();
    if (ctx.validationIssues() != issuesBefore_) {
      std::string all;
      for (size_t i = issuesBefore_; i < ctx.validationMessages().size(); ++i)
        all += ctx.validationMessages()[i] + "\n";
      ADD_FAILURE() << "validation layer reported " << (ctx.validationIssues() - issuesBefore_) << " issue(s):\n"
                    << all;
    }
  }
  gpu::Context& context() { return gpuContext(); }

private:
  uint32_t issuesBefore_ = 0;
};

} // namespace mirage::test
