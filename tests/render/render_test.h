// Shared by the render tests on the device: a Vulkan context that can draw (graphics queue) with
// the Khronos validation layer on, and one offscreen renderer for the whole suite. Any validation
// message fails the test that caused it; a missing device or layer fails the suite.
#pragma once
#include "render/offscreen.h"
#include "vk/context.h"

#include <gtest/gtest.h>
#include <memory>

namespace shprobe::testing {

class RenderTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        ContextOptions options;
        options.validation = true;
        options.graphics = true;
        context_ = std::make_unique<Context>(createContext(options));
        renderer_ = std::make_unique<OffscreenRenderer>(createOffscreenRenderer(*context_));
    }
    static void TearDownTestSuite() {
        destroyOffscreenRenderer(*context_, *renderer_);
        destroyContext(*context_);
        EXPECT_EQ(context_->validationMessages(), 0u) << "validation messages while destroying the context";
        renderer_.reset();
        context_.reset();
    }
    void SetUp() override { messagesBefore_ = context_->validationMessages(); }
    void TearDown() override {
        EXPECT_EQ(context_->validationMessages(), messagesBefore_)
            << "Vulkan validation messages (see stderr)";
    }

  public:
    static const Context& context() { return *context_; }
    static OffscreenRenderer& renderer() { return *renderer_; }

  private:
    static inline std::unique_ptr<Context> context_;
    static inline std::unique_ptr<OffscreenRenderer> renderer_;
    uint32_t messagesBefore_ = 0;
};

} // namespace shprobe::testing
