// Test DICOM slides made at test time by OrthancWSIDicomizer (Debian orthanc-wsi), shared by the
// suites that need them (tests/dicomweb; tests/engine/tst_dicom.cpp has the same helper).
#pragma once

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

namespace iristest {

// Whether OrthancWSIDicomizer is on the PATH.
inline bool dicomizerInstalled() { return std::system("command -v OrthancWSIDicomizer > /dev/null 2>&1") == 0; }

// Runs OrthancWSIDicomizer on `source` into the fresh folder `out` (removed first), with
// `options` (e.g. "--reencode=0 --max-size=1"); its output goes to `out`.log. On failure
// returns nothing and says why.
inline std::optional<std::filesystem::path> dicomize(const std::filesystem::path& out,
                                                     const std::filesystem::path& source, const std::string& options,
                                                     std::string* why) {
    std::filesystem::remove_all(out);
    std::filesystem::create_directories(out);
    const std::string cmd = "OrthancWSIDicomizer --threads=1 --folder='" + out.string() + "' " + options + " '" +
                            source.string() + "' > '" + out.string() + ".log' 2>&1";
    if (std::system(cmd.c_str()) != 0) {
        *why = "OrthancWSIDicomizer failed: " + cmd + " (see " + out.string() + ".log)";
        return std::nullopt;
    }
    return out;
}

} // namespace iristest
