// An HTTP/2 server in front of the suite's Orthanc (which speaks HTTP/1.1 only): nghttpx
// (Debian nghttp2-proxy), a real HTTP/2 reverse proxy, started on 127.0.0.1 at a free port with
// TLS (a certificate the suite's CA signed; HTTP/2 over TLS is negotiated by ALPN), and stopped
// by its PID. Its access log names the protocol of every request ($alpn: "h2" for HTTP/2), so
// a test can check what the client spoke from the server's side.
//
// Every wait is bounded: start() polls the port until it accepts (at most 15 s) while the
// process runs; stop() waits at most 10 s after SIGTERM before SIGKILL.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace dicomwebtest {

namespace fs = std::filesystem;

class H2Server {
public:
    // nghttpx in `dir` (logs), forwarding to http://127.0.0.1:backendPort; nullptr and *why on
    // failure (nghttpx missing, not listening in time).
    static std::unique_ptr<H2Server> start(const fs::path& dir, int backendPort, const fs::path& certificate,
                                           const fs::path& key, std::string* why);
    ~H2Server(); // stops it
    H2Server(const H2Server&) = delete;
    H2Server& operator=(const H2Server&) = delete;

    bool stop();
    int port() const { return port_; }
    // The access log's lines so far: "<alpn> <client port> <method> <path> <status>" each.
    std::vector<std::string> accessLog() const;

private:
    H2Server() = default;
    fs::path dir_;
    int port_ = 0;
    pid_t pid_ = -1;
};

} // namespace dicomwebtest
