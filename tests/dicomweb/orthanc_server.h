// A real Orthanc (Debian orthanc + orthanc-dicomweb) for the DICOMweb suite: started on
// 127.0.0.1 at a free port with a generated configuration and a storage folder of its own,
// stopped by its PID. Uploads go through its REST API (POST /instances) with libcurl.
//
// Every wait is bounded: start() polls GET /system until Orthanc answers (at most 30 s), stop()
// waits at most 10 s for the process after SIGTERM before SIGKILL.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <memory>
#include <string>

namespace dicomwebtest {

namespace fs = std::filesystem;

// Plain HTTP only: Debian 12's Orthanc 1.10.1 crashes on its first HTTPS request (its
// libcivetweb calls a null OpenSSL function), so the suite's TLS server is fault_proxy.h.
struct OrthancOptions {
    std::string user, password; // basic authentication on, when user is not empty
};

class OrthancServer {
public:
    // Starts Orthanc in `dir` (configuration, storage, log). nullptr and *why on failure.
    static std::unique_ptr<OrthancServer> start(const fs::path& dir, const OrthancOptions& options, std::string* why);
    ~OrthancServer(); // stops it
    OrthancServer(const OrthancServer&) = delete;
    OrthancServer& operator=(const OrthancServer&) = delete;

    // SIGTERM, then SIGKILL after 10 s; true once the process is gone.
    bool stop();
    // Starts it again on the same port and storage (after stop()).
    bool restart(std::string* why);
    bool running() const { return pid_ > 0; }

    int port() const { return port_; }
    // http://127.0.0.1:PORT/dicom-web
    std::string dicomWebRoot() const;
    // The series URL of a DICOM file's series (its Study and Series Instance UIDs read with DCMTK).
    std::string seriesUrl(const fs::path& dicomFile) const;
    // Uploads every regular file of `folder` (or the one file); false and *why on failure.
    bool upload(const fs::path& path, std::string* why) const;
    const fs::path& log() const { return logPath_; }

private:
    OrthancServer() = default;
    bool launch(std::string* why);

    fs::path dir_;
    fs::path logPath_;
    OrthancOptions options_;
    int port_ = 0;
    pid_t pid_ = -1;
};

// A TCP port on 127.0.0.1 that nothing listens on right now.
int freeLoopbackPort();

} // namespace dicomwebtest
