#include "net/multipart.h"

#include <algorithm>
#include <charconv>
#include <optional>

namespace iris::net {

namespace {

constexpr size_t kMaxParts = size_t(1) << 16;
constexpr size_t kMaxHeaderLine = 8192;
constexpr size_t kMaxHeaders = 64;
constexpr size_t kMaxBoundary = 200; // RFC 2046 allows 70; servers stay far below either

Result bad(const std::string& why) { return Result(Status::CorruptData, why); }

bool isSpace(char c) { return c == ' ' || c == '\t'; }

std::string lower(std::string_view s) {
    std::string out(s);
    for (char& c : out)
        if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
    return out;
}

std::string_view trim(std::string_view s) {
    while (!s.empty() && isSpace(s.front())) s.remove_prefix(1);
    while (!s.empty() && isSpace(s.back())) s.remove_suffix(1);
    return s;
}

// RFC 9110 token characters.
bool isToken(char c) {
    if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9')) return true;
    return std::string_view("!#$%&'*+-.^_`|~").find(c) != std::string_view::npos;
}

// The body as a cursor. Every read checks the end first.
class Cursor {
public:
    Cursor(const uint8_t* data, size_t size) : s_(reinterpret_cast<const char*>(data), size) {}
    size_t pos() const { return pos_; }
    size_t left() const { return s_.size() - pos_; }
    bool startsWith(std::string_view p) const { return s_.compare(pos_, p.size(), p) == 0 && left() >= p.size(); }
    void skip(size_t n) { pos_ += std::min(n, left()); }
    // The next line without its CRLF (or bare LF); false when no line end follows within max.
    bool line(std::string_view* out, size_t max) {
        const size_t end = s_.find('\n', pos_);
        if (end == std::string_view::npos || end - pos_ > max) return false;
        size_t stop = end;
        if (stop > pos_ && s_[stop - 1] == '\r') --stop;
        *out = s_.substr(pos_, stop - pos_);
        pos_ = end + 1;
        return true;
    }
    size_t find(std::string_view what, size_t from) const { return s_.find(what, from); }
    std::string_view view() const { return s_; }

private:
    std::string_view s_;
    size_t pos_ = 0;
};

} // namespace

const std::string* MediaType::param(std::string_view name) const {
    for (const auto& [k, v] : params)
        if (k == name) return &v;
    return nullptr;
}

Expected<MediaType> parseMediaType(std::string_view text) {
    MediaType m;
    size_t i = 0;
    const auto skipSpace = [&] {
        while (i < text.size() && isSpace(text[i])) ++i;
    };
    skipSpace();
    const size_t t0 = i;
    while (i < text.size() && (isToken(text[i]) || text[i] == '/')) ++i;
    const std::string_view type = text.substr(t0, i - t0);
    const size_t slash = type.find('/');
    if (type.empty() || slash == 0 || slash == std::string_view::npos || slash + 1 == type.size() ||
        type.find('/', slash + 1) != std::string_view::npos) {
        std::string what(1, '\'');
        what.append(text.substr(0, 200)).append("' is not a media type (type/subtype)");
        return bad(what);
    }
    m.type = lower(type);
    for (;;) {
        skipSpace();
        if (i == text.size()) break;
        if (text[i] != ';') {
            return bad("media type '" + m.type + "': unexpected '" + std::string(1, text[i]) + "' at character " +
                       std::to_string(i + 1));
        }
        ++i;
        skipSpace();
        if (i == text.size()) break; // a trailing ';'
        const size_t n0 = i;
        while (i < text.size() && isToken(text[i])) ++i;
        const std::string name = lower(text.substr(n0, i - n0));
        skipSpace();
        if (name.empty() || i == text.size() || text[i] != '=') {
            return bad("media type '" + m.type + "': parameter " + std::to_string(m.params.size() + 1) +
                       " is not name=value");
        }
        ++i;
        skipSpace();
        std::string value;
        if (i < text.size() && text[i] == '"') {
            ++i;
            bool closed = false;
            while (i < text.size()) {
                const char c = text[i++];
                if (c == '"') {
                    closed = true;
                    break;
                }
                if (c == '\\') {
                    if (i == text.size()) break;
                    value.push_back(text[i++]);
                } else {
                    value.push_back(c);
                }
            }
            if (!closed) return bad("media type '" + m.type + "': the value of '" + name + "' has no closing quote");
        } else {
            const size_t v0 = i;
            while (i < text.size() && text[i] != ';' && !isSpace(text[i])) ++i;
            value = std::string(text.substr(v0, i - v0));
        }
        m.params.emplace_back(name, std::move(value));
    }
    return m;
}

Expected<std::vector<Part>> parseMultipart(std::string_view contentType, const uint8_t* body, size_t size) {
    auto mt = parseMediaType(contentType);
    if (!mt.ok()) return mt.error();
    if (mt->type.rfind("multipart/", 0) != 0) return bad("the body is '" + mt->type + "', not multipart");
    const std::string* boundary = mt->param("boundary");
    if (!boundary || boundary->empty() || boundary->size() > kMaxBoundary) {
        return bad("the multipart Content-Type has " +
                   std::string(boundary && !boundary->empty() ? "an overlong" : "no") + " boundary");
    }
    const std::string delimiter = "--" + *boundary;
    const std::string inner = "\r\n" + delimiter; // what ends a part's body
    if (!body && size > 0) return bad("no body");
    Cursor c(body, size);

    // The first delimiter, at the very start or at the start of a line (a preamble may precede it).
    size_t first = c.view().rfind(delimiter, 0) == 0 ? 0 : std::string_view::npos;
    for (size_t from = 0; first == std::string_view::npos;) {
        const size_t at = c.find(delimiter, from);
        if (at == std::string_view::npos) return bad("the multipart body holds no delimiter (--boundary)");
        if (at > 0 && c.view()[at - 1] == '\n') first = at;
        from = at + 1;
    }
    c.skip(first + delimiter.size());

    std::vector<Part> parts;
    for (;;) {
        // After a delimiter: "--" closes the body; otherwise optional padding and a line end.
        if (c.startsWith("--")) {
            if (parts.empty()) return bad("the multipart body has no part");
            return parts;
        }
        std::string_view rest;
        if (!c.line(&rest, kMaxHeaderLine) || !trim(rest).empty()) {
            return bad("the multipart body is cut short or malformed after delimiter " +
                       std::to_string(parts.size() + 1) + " (byte " + std::to_string(c.pos()) + ")");
        }
        if (parts.size() >= kMaxParts)
            return bad("the multipart body has more than " + std::to_string(kMaxParts) + " parts");
        Part part;
        const std::string where = "part " + std::to_string(parts.size() + 1);
        std::optional<uint64_t> length;
        for (size_t n = 0;; ++n) {
            std::string_view line;
            if (!c.line(&line, kMaxHeaderLine)) {
                return bad(where + ": its headers are cut short (byte " + std::to_string(c.pos()) + ")");
            }
            if (line.empty()) break;
            if (n >= kMaxHeaders) return bad(where + " has more than " + std::to_string(kMaxHeaders) + " headers");
            const size_t colon = line.find(':');
            if (colon == std::string_view::npos || colon == 0) {
                return bad(where + ": header line " + std::to_string(n + 1) + " has no 'name:'");
            }
            const std::string name = lower(trim(line.substr(0, colon)));
            const std::string_view value = trim(line.substr(colon + 1));
            if (name == "content-type") {
                part.contentType = std::string(value);
            } else if (name == "content-location") {
                part.contentLocation = std::string(value);
            } else if (name == "content-length") {
                uint64_t v = 0;
                const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), v);
                if (ec != std::errc() || end != value.data() + value.size()) {
                    return bad(where + ": Content-Length '" + std::string(value.substr(0, 40)) + "' is not a number");
                }
                length = v;
            }
        }
        const size_t start = c.pos();
        size_t end = 0;
        if (length) {
            if (*length > c.left()) {
                return bad(where + " is cut short: its Content-Length is " + std::to_string(*length) + " but only " +
                           std::to_string(c.left()) + " bytes follow");
            }
            end = start + size_t(*length);
            if (c.view().compare(end, inner.size(), inner) != 0) {
                return bad(where + ": its " + std::to_string(*length) +
                           " bytes (Content-Length) are not followed by the delimiter");
            }
        } else {
            end = c.find(inner, start);
            if (end == std::string_view::npos) {
                return bad(where + " is cut short: no delimiter follows its body (" + std::to_string(c.left()) +
                           " bytes)");
            }
        }
        part.data = body + start;
        part.size = end - start;
        parts.push_back(std::move(part));
        c.skip(end + inner.size() - start);
        if (c.left() == 0) {
            return bad("the multipart body is cut short after " + std::to_string(parts.size()) +
                       " parts (no closing delimiter)");
        }
    }
}

uint32_t locatedFrame(std::string_view location) {
    constexpr std::string_view kFrames = "/frames/";
    const size_t at = location.rfind(kFrames);
    if (at == std::string_view::npos) return 0;
    const std::string_view digits = location.substr(at + kFrames.size());
    uint32_t n = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), n);
    if (ec != std::errc() || end != digits.data() + digits.size() || digits.empty() || digits.front() == '+') return 0;
    return n;
}

Result checkFrameParts(const std::vector<Part>& parts, const std::vector<uint32_t>& frames) {
    if (parts.size() != frames.size()) {
        return bad("the answer holds " + std::to_string(parts.size()) + " part" + (parts.size() == 1 ? "" : "s") +
                   (frames.size() == 1 ? ", not the one frame asked for"
                                       : " for the " + std::to_string(frames.size()) + " frames asked for"));
    }
    for (size_t i = 0; i < parts.size(); ++i) {
        const uint32_t named = locatedFrame(parts[i].contentLocation);
        if (named != 0 && named != frames[i]) {
            return bad("part " + std::to_string(i + 1) + " of the answer is frame " + std::to_string(named) +
                       " (its Content-Location), where frame " + std::to_string(frames[i]) + " was asked for");
        }
    }
    return {};
}

} // namespace iris::net
