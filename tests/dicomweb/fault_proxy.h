// A small HTTP/1.1 proxy on 127.0.0.1 in front of the suite's Orthanc, with plain sockets (and
// OpenSSL when it terminates TLS), that misbehaves on purpose for WADO-RS frame requests (…/frames/<n> and frame lists
// …/frames/<a>,<b>,…): it holds answers back until the test lets them go (a server that does not answer yet), cuts the
// multipart body short, gives a wrong Content-Type, drops or swaps parts of a frame list's answer, answers 404 or 503,
// or refuses frame lists (400, as some servers do); or answers any request of a path (QIDO-RS searches) with a body of
// the test's choosing. Everything else passes unchanged. It keeps connections alive like a server (one thread per
// client connection) and fetches from upstream with libcurl. It counts the frame requests it saw, the frames they
// asked for and the frame answers it sent, so that a test can tell how many a walk cost and whether it batched.
//
// TLS: Debian 12's Orthanc 1.10.1 crashes on its first HTTPS request (its libcivetweb calls a
// null OpenSSL function), so the suite's HTTPS server is this proxy, given a certificate and key.
//
// Bounded: sockets have receive timeouts, a delay sleeps in short steps, and stopping (the
// destructor) closes the listening socket and every connection, then joins every thread.
#pragma once

#include <atomic>
#include <condition_variable>
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
        Hold,        // no answer until the rule changes (or holdMs passed): a server that has not answered yet
        Truncate,    // the multipart body loses its last part of the data and its closing delimiter
        WrongType,   // Content-Type: text/html
        NotFound,    // HTTP 404
        Unavailable, // HTTP 503 (a server that is down behind a gateway), answered at once
        DropPart,    // a frame list's answer loses its last part (one part fewer than frames asked for)
        SwapParts,   // a frame list's answer has its first two parts swapped (each still names its frame)
        RefuseLists, // HTTP 400 for every frame list; single frames pass
        Replace,     // any request whose path holds `pathContains` gets `status`, `type` and `body` (a lying server)
    };
    struct Rule {
        Fault fault = Fault::None;
        int holdMs = 60000;
        // A request whose frames are all numbered below this passes unchanged (frame 1 is read
        // at open); a list with any frame from here on gets the fault.
        int fromFrame = 1;
        bool listsOnly = false; // the fault hits frame lists only; single frames pass
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
    // Replaces the rule; answers held by the old one go (with the new rule's faults, if any).
    void setRule(const Rule& rule);
    // Frame requests (single or list), those that were lists, the frames they asked for, and
    // frame answers sent back since the last resetCount().
    int frameRequests() const { return requests_.load(std::memory_order_relaxed); }
    int listRequests() const { return lists_.load(std::memory_order_relaxed); }
    int framesAsked() const { return frames_.load(std::memory_order_relaxed); }
    int frameAnswers() const { return answers_.load(std::memory_order_relaxed); }
    void resetCount() {
        requests_.store(0, std::memory_order_relaxed);
        lists_.store(0, std::memory_order_relaxed);
        frames_.store(0, std::memory_order_relaxed);
        answers_.store(0, std::memory_order_relaxed);
    }

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
    // Relaxed: statistics read after the walk they count.
    std::atomic<int> requests_{0}, lists_{0}, frames_{0}, answers_{0};
    mutable std::mutex mutex_;            // guards rule_, ruleSerial_, clients_, threads_
    std::condition_variable ruleChanged_; // a held answer waits on it (with mutex_)
    Rule rule_;
    uint64_t ruleSerial_ = 0;
    std::vector<int> clients_;
    std::vector<std::thread> threads_;
    std::thread acceptor_;
};

} // namespace dicomwebtest
