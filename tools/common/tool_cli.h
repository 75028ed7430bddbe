// The command line every Iris View tool shares: CLI11 set up so that --help is in the layout
// help2man turns into a man page, --version prints "NAME (Iris View) VERSION", and a usage
// error is one line on stderr naming the option, exit status 2.
#pragma once

#include <charconv>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include <CLI/CLI.hpp>
#include <iris/version.h>

namespace iris::tools {

// The footer paragraph of a tool that maps the IRIS_* variables onto EngineTuning
// (iris::tuningFromEnvironment, iris/environment.h).
inline constexpr const char* kTuningEnvironmentHelp =
    "\n\nEnvironment (EngineTuning, see iris/environment.h):\n"
    "  IRIS_PACE_FRAMES=0|1           frame pacing off/on (default: on for CPU\n"
    "                                 devices, for frames of 0.25 ms or more on GPUs)\n"
    "  IRIS_DRAW_COVERED=0|1          draw tiles hidden under finer ones\n"
    "  IRIS_MIP_SCHEDULE=wide|serial|host  who makes the mips (default: by device type)\n"
    "  IRIS_DEVICE=TEXT               use the Vulkan device whose name contains TEXT\n"
    "  IRIS_QUEUES=single|auto        every role on the graphics queue\n"
    "  IRIS_TILE_RESOLVE=auto|quads|compute  tiles as quads, or resolved per pixel\n"
    "                                 (default: compute offscreen on a GPU)\n"
    "  IRIS_COLOR_LOOKUP=auto|sampler|nodes  the colour table's interpolation\n"
    "                                 (default: sampler)\n"
    "  IRIS_EXACT_COPY=auto|0|1       copy levels at their own scale, not draw them\n"
    "                                 (default: on for CPU devices)\n"
    "  IRIS_TILE_UPLOAD=auto|queue|host  tiles into the atlas by a queue copy or by\n"
    "                                 host writes (default: host for CPU devices)\n"
    "  IRIS_JPEG_DECODE=auto|cpu|gpu  finish JPEG tiles (inverse DCT, upsampling,\n"
    "                                 colour) on the GPU (default: gpu on GPUs)";

// "  -o, --output FILE       text (default: x)" within 80 columns.
class HelpFormatter : public CLI::Formatter {
public:
    static constexpr size_t kNameColumn = 26;
    HelpFormatter() { column_width(kNameColumn); }
    std::string make_option_name(const CLI::Option* opt, bool positional) const override {
        std::string names = CLI::Formatter::make_option_name(opt, positional);
        for (size_t i = names.find(','); i != std::string::npos; i = names.find(',', i + 2)) names.replace(i, 1, ", ");
        return names;
    }
    std::string make_option_opts(const CLI::Option* opt) const override {
        return opt->get_positional() ? std::string() : CLI::Formatter::make_option_opts(opt);
    }
    std::string make_option_desc(const CLI::Option* opt) const override {
        const std::string desc = opt->get_description(), def = opt->get_default_str();
        if (def.empty()) return desc;
        const std::string suffix = "(default: " + def + ")";
        const size_t lastLine = desc.size() - (desc.rfind('\n') + 1); // (no newline: npos + 1 == 0)
        return desc + (lastLine + 1 + suffix.size() > 80 - kNameColumn ? "\n" : " ") + suffix;
    }
};

// The flags and layout every tool has; `name` must outlive the app (a string literal).
inline void setUpApp(CLI::App& app, const char* name) {
    app.name(name);
    app.formatter(std::make_shared<HelpFormatter>());
    app.get_formatter()->label("Positionals", "Arguments");
    app.set_help_flag("-h,--help", "Print this help and exit");
    app.set_version_flag("--version", std::string(name) + " (Iris View) " + IRIS_VIEW_VERSION_STRING,
                         "Print the version and exit");
    app.option_defaults()->always_capture_default();
}

// A usage error: one line naming the option and a pointer to --help; exit status 2.
inline int usageError(const CLI::App& app, const std::string& message) {
    std::fprintf(stderr, "%s: error: %s\nRun with --help for more information.\n", app.get_name().c_str(),
                 message.c_str());
    return 2;
}

// Parses argv: -1 to go on, else the exit status (--help and --version print to stdout, 0).
// `missingRequired`, when given, replaces CLI11's message for a missing required argument
// (for a tool whose only required argument is its input).
inline int parseArguments(CLI::App& app, int argc, char** argv, const std::string& missingRequired = {}) {
    try {
        app.parse(argc, argv);
        return -1;
    } catch (const CLI::Success& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // A stray argument is named first: CLI11 reports a missing required argument before it,
        // though the stray one is the likelier mistake.
        if (const std::vector<std::string> extra = app.remaining(); !extra.empty())
            return usageError(app, (extra[0].starts_with('-') ? "unknown option " : "unexpected argument ") + extra[0]);
        if (!missingRequired.empty() && dynamic_cast<const CLI::RequiredError*>(&e))
            return usageError(app, missingRequired);
        return usageError(app, e.what());
    }
}

// A whole decimal number from lo to hi. It rewrites the text in plain decimal, which CLI11 then
// converts: on its own CLI11 reads a leading 0 as octal and wraps -1 round to 2^64-1.
template <typename T>
CLI::Validator wholeNumber(T lo, T hi = std::numeric_limits<T>::max()) {
    return CLI::Validator(
        [lo, hi](std::string& text) {
            T value{};
            const char* end = text.data() + text.size();
            const auto [ptr, ec] = std::from_chars(text.data(), end, value);
            if (text.empty() || ec != std::errc() || ptr != end || value < lo || value > hi)
                return "'" + text + "' is not a whole number from " + std::to_string(lo) + " to " + std::to_string(hi);
            text = std::to_string(value);
            return std::string();
        },
        "");
}

// A check by predicate: passes the text when ok(text), else says "'TEXT' is not WHAT".
inline CLI::Validator textCheck(bool (*ok)(const std::string&), const std::string& what) {
    return CLI::Validator(
        [ok, what](std::string& text) { return ok(text) ? std::string() : "'" + text + "' is not " + what; }, "");
}

} // namespace iris::tools
