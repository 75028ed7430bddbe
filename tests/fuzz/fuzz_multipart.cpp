// libFuzzer target for the multipart/related parser of the DICOMweb source
// (engine/src/net/multipart.cpp), see README.md.
//
// An input is a message as the network source gets it: its first line is the Content-Type
// header's value, the rest the body. It goes through what the source does with a frame answer
// (one frame, or a frame list …/frames/a,b,c):
//   net::parseMediaType()   the message's Content-Type, and each part's;
//   net::parseMultipart()   the parts;
//   net::checkFrameParts()  the parts against the frames asked for (each part's Content-Location
//                           read by net::locatedFrame()).
// Besides the sanitizers, it checks what these promise their caller and aborts when a promise
// is broken: every part lies inside the body, parts do not overlap and come in order, a success
// has at least one part, a failure has a message; checkFrameParts accepts a list only when it
// has one part per frame and no part names another frame than the one in its place.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_signals.h"
#include "net/multipart.h"

namespace {

[[noreturn]] void broken(const char* what, int line) {
    std::fprintf(stderr, "fuzz_multipart.cpp:%d: broken promise: %s\n", line, what);
    std::abort();
}
#define PROMISE(cond)                                                                                                  \
    do {                                                                                                               \
        if (!(cond)) broken(#cond, __LINE__);                                                                          \
    } while (0)

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view all(reinterpret_cast<const char*>(data), size);
    const size_t eol = all.find('\n');
    const std::string_view contentType = all.substr(0, eol == std::string_view::npos ? all.size() : eol);
    const size_t offset = eol == std::string_view::npos ? size : eol + 1;
    const uint8_t* body = data + offset;
    const size_t bodySize = size - offset;

    auto type = iris::net::parseMediaType(contentType);
    PROMISE(type.ok() || !type.error().message().empty());
    if (type.ok()) {
        PROMISE(!type->type.empty() && type->type.find('/') != std::string::npos);
        for (const auto& [name, value] : type->params) PROMISE(!name.empty());
    }

    auto parts = iris::net::parseMultipart(contentType, body, bodySize);
    if (!parts.ok()) {
        PROMISE(!parts.error().message().empty());
        PROMISE(parts.error().status() == iris::Status::CorruptData);
        return 0;
    }
    PROMISE(!parts->empty());
    const uint8_t* previousEnd = body;
    for (const iris::net::Part& p : *parts) {
        PROMISE(p.data >= body && p.data + p.size <= body + bodySize);
        PROMISE(p.data >= previousEnd);
        previousEnd = p.data + p.size;
        // What the source does next with a part: its own media type.
        if (!p.contentType.empty()) {
            auto t = iris::net::parseMediaType(p.contentType);
            PROMISE(t.ok() || !t.error().message().empty());
        }
        volatile uint8_t sink = 0;
        for (size_t i = 0; i < p.size; ++i) sink = sink ^ p.data[i]; // ASan checks every byte is readable
        (void)sink;
    }
    // The frames the parts name, or their place (from 1) where they name none: the list they
    // answer, which checkFrameParts must accept; a list one frame longer it must refuse.
    std::vector<uint32_t> named, places;
    for (size_t i = 0; i < parts->size(); ++i) {
        const uint32_t n = iris::net::locatedFrame((*parts)[i].contentLocation);
        named.push_back(n != 0 ? n : uint32_t(i + 1));
        places.push_back(uint32_t(i + 1));
    }
    PROMISE(iris::net::checkFrameParts(*parts, named).ok());
    const iris::Result inOrder = iris::net::checkFrameParts(*parts, places);
    PROMISE(inOrder.ok() || inOrder.status() == iris::Status::CorruptData);
    for (size_t i = 0; i < parts->size(); ++i) {
        const uint32_t n = iris::net::locatedFrame((*parts)[i].contentLocation);
        if (inOrder.ok()) PROMISE(n == 0 || n == places[i]); // never a frame in another's place
    }
    named.push_back(1);
    const iris::Result longer = iris::net::checkFrameParts(*parts, named);
    PROMISE(!longer.ok() && !longer.message().empty());
    return 0;
}
