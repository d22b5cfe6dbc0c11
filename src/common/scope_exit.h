// Cleanup where the resource is created. A function that creates several resources registers
// each one's destroy right after its create:
//
//   Buffer staging = createBuffer(...);
//   ScopeExit releaseStaging([&] { destroyBuffer(device, staging); });   // always, at scope end
//
//   ProbeBaker baker;
//   OnFailure undo([&] { destroyProbeBaker(device, baker); });            // only if an exception
//   baker.sampler = createSampler(...);                                    // leaves the scope
//
// Guards run in reverse order of their construction, so resources go in reverse order of
// creation. The handles stay plain Vulkan handles in plain structs (what an engine stores and
// destroys itself), and each type keeps the one destroy function its users call: a guard runs
// that function on a partly made object (destroy functions skip null handles) instead of a second
// list of destroy calls. Cleanups must not throw; destroy functions do not.
#pragma once
#include <exception>
#include <utility>

namespace shprobe {

template <typename Cleanup> class ScopeExit {
  public:
    explicit ScopeExit(Cleanup cleanup) : cleanup_(std::move(cleanup)) {}
    ~ScopeExit() { cleanup_(); }
    ScopeExit(const ScopeExit&) = delete;
    ScopeExit& operator=(const ScopeExit&) = delete;

  private:
    Cleanup cleanup_;
};

template <typename Cleanup> class OnFailure {
  public:
    explicit OnFailure(Cleanup cleanup)
        : cleanup_(std::move(cleanup)), exceptionsBefore_(std::uncaught_exceptions()) {}
    ~OnFailure() {
        if (std::uncaught_exceptions() > exceptionsBefore_) cleanup_();
    }
    OnFailure(const OnFailure&) = delete;
    OnFailure& operator=(const OnFailure&) = delete;

  private:
    Cleanup cleanup_;
    int exceptionsBefore_;
};

} // namespace shprobe
