// Shared by the GPU tests: one Vulkan context on the selected device (lavapipe in CI through
// VK_ICD_FILENAMES) with the Khronos validation layer on. Any validation message fails the test
// that caused it; a missing device or layer fails the suite, never skips it.
#pragma once
#include "vk/context.h"

#include <gtest/gtest.h>
#include <memory>

namespace shprobe::testing {

class GpuTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        ContextOptions options;
        options.validation = true;
        context_ = std::make_unique<Context>(createContext(options));
    }
    static void TearDownTestSuite() {
        destroyContext(*context_);
        EXPECT_EQ(context_->validationMessages(), 0u) << "validation messages while destroying the context";
        context_.reset();
    }
    void SetUp() override { messagesBefore_ = context_->validationMessages(); }
    void TearDown() override {
        EXPECT_EQ(context_->validationMessages(), messagesBefore_)
            << "Vulkan validation messages (see stderr)";
    }

    static const Context& context() { return *context_; }

  private:
    static inline std::unique_ptr<Context> context_;
    uint32_t messagesBefore_ = 0;
};

} // namespace shprobe::testing
