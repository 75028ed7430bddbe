// A small HTTP/1.1 proxy on 127.0.0.1 in front of the suite's Orthanc, with plain sockets (and
// OpenSSL when it terminates TLS), that misbehaves on purpose for WADO-RS frame requests: it delays answers (a slow
// server), cuts the multipart body short, gives a wrong Content-Type, or answers 404 or 503; or answers any request of
// a path (QIDO-RS searches) with a body of the test's choosing. Everything else passes unchanged. It keeps connections
// alive like a server (one thread per client connection) and fetches from upstream with libcurl. It counts the frame
// requests it saw, so that a test can tell how many a walk cost.
//
// TLS: Debian 12's Orthanc 1.10.1 crashes on its first HTTPS request (its libcivetweb calls a
// null OpenSSL function), so the suite's HTTPS server is this proxy, given a certificate and key.
//
// Bounded: sockets have receive timeouts, a delay sleeps in short steps, and stopping (the
// destructor) closes the listening socket and every connection, then joins every thread.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace dicomwebtest {

class FaultProxy {
public:
    enum class Fault {
        None,
        Delay,       // answer delayMs late
        Truncate,    // the multipart body loses its last part of the data and its closing delimiter
        WrongType,   // Content-Type: text/html
        NotFound,    // HTTP 404
        Unavailable, // HTTP 503 (a server that is down behind a gateway), answered at once
        Replace,     // any request whose path holds `pathContains` gets `status`, `type` and `body` (a lying server)
    };
    struct Rule {
        Fault fault = Fault::None;
        int delayMs = 0;
        int fromFrame = 1; // frames numbered below this pass unchanged (frame 1 is read at open)
        // Replace only:
        std::string pathContains;
        long status = 200;
        std::string type, body;
    };

    struct Tls {
        std::string certificate; // PEM: the server certificate (and chain)
        std::string key;         // PEM: its private key
    };
    // Listens on a free loopback port (speaking TLS with `tls`) and forwards to
    // http://127.0.0.1:upstreamPort.
    static std::unique_ptr<FaultProxy> start(int upstreamPort, std::string* why, const Tls* tls = nullptr);
    ~FaultProxy();
    FaultProxy(const FaultProxy&) = delete;
    FaultProxy& operator=(const FaultProxy&) = delete;

    int port() const { return port_; }
    void setRule(const Rule& rule);
    int frameRequests() const { return frames_.load(std::memory_order_relaxed); }
    void resetCount() { frames_.store(0, std::memory_order_relaxed); }

private:
    FaultProxy() = default;
    void acceptLoop();
    void serve(int client);
    Rule rule() const;

    void* tls_ = nullptr; // SSL_CTX*, when the proxy speaks TLS
    int upstream_ = 0;
    int port_ = 0;
    int listen_ = -1;
    // Set by the destructor (release), read by every thread between blocking calls (acquire).
    std::atomic<bool> stop_{false};
    // Relaxed: a statistic read after the walk it counts.
    std::atomic<int> frames_{0};
    mutable std::mutex mutex_; // guards rule_, clients_, threads_
    Rule rule_;
    std::vector<int> clients_;
    std::vector<std::thread> threads_;
    std::thread acceptor_;
};

} // namespace dicomwebtest
