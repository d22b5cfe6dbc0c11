// The one exception type of the library: a message that says what was being done and what failed.
#pragma once
#include <stdexcept>
#include <string>

namespace shprobe {

// Why a run failed, which decides the program's exit code.
enum class ErrorKind {
    Input,  // a file, an option or data given by the user is unusable
    Output, // an output file could not be written
    Device, // no usable Vulkan device or Embree, or the device failed
    Memory, // the machine cannot allocate what the work needs
};

class Error : public std::runtime_error {
  public:
    Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
    ErrorKind kind() const { return kind_; }

  private:
    ErrorKind kind_;
};

} // namespace shprobe
