#include "iris/types.h"

namespace iris {

const char* statusName(Status s) noexcept {
    switch (s) {
    case Status::Ok: return "ok";
    case Status::InvalidArgument: return "invalid argument";
    case Status::NotFound: return "not found";
    case Status::NotAFile: return "not a file";
    case Status::UnsupportedFormat: return "unsupported format";
    case Status::CorruptData: return "corrupt data";
    case Status::IoError: return "I/O error";
    case Status::OutOfMemory: return "out of memory";
    case Status::Vulkan: return "Vulkan error";
    case Status::DeviceLost: return "device lost";
    case Status::NoSlide: return "no slide";
    case Status::NotBound: return "no render target";
    case Status::Timeout: return "timeout";
    case Status::Cancelled: return "cancelled";
    case Status::SurfaceLost: return "surface lost";
    }
    return "unknown";
}

} // namespace iris
