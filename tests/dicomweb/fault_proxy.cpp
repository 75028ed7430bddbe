#include "fault_proxy.h"

#include <pthread.h>
#include <signal.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>

#include <curl/curl.h>
#include <openssl/err.h>
#include <openssl/ssl.h>

namespace dicomwebtest {

namespace {

size_t collect(char* data, size_t size, size_t n, void* out) {
    static_cast<std::string*>(out)->append(data, size * n);
    return size * n;
}

// A client connection, plain or TLS.
struct Conn {
    int fd = -1;
    SSL* ssl = nullptr;
    // >0: bytes read; 0: closed or failed; -1: nothing yet (the receive timeout passed).
    ssize_t read(char* buf, size_t n) {
        if (!ssl) {
            const ssize_t r = ::recv(fd, buf, n, 0);
            if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return -1;
            return r < 0 ? 0 : r;
        }
        const int r = SSL_read(ssl, buf, int(n));
        if (r > 0) return r;
        const int e = SSL_get_error(ssl, r);
        return e == SSL_ERROR_WANT_READ || e == SSL_ERROR_WANT_WRITE ? -1 : 0;
    }
    bool write(const std::string& s) {
        size_t at = 0;
        while (at < s.size()) {
            const ssize_t n = ssl ? SSL_write(ssl, s.data() + at, int(s.size() - at))
                                  : ::send(fd, s.data() + at, s.size() - at, MSG_NOSIGNAL);
            if (n <= 0) return false;
            at += size_t(n);
        }
        return true;
    }
};

// The value of header `name` (given lower case) in a request head, or "".
std::string header(const std::string& head, const std::string& name) {
    size_t at = head.find("\r\n");
    while (at != std::string::npos && at + 2 < head.size()) {
        const size_t end = head.find("\r\n", at + 2);
        const std::string line = head.substr(at + 2, end == std::string::npos ? std::string::npos : end - at - 2);
        const size_t colon = line.find(':');
        if (colon != std::string::npos) {
            std::string key = line.substr(0, colon);
            for (char& c : key) c = char(std::tolower(static_cast<unsigned char>(c)));
            if (key == name) {
                size_t v = colon + 1;
                while (v < line.size() && line[v] == ' ') ++v;
                return line.substr(v);
            }
        }
        at = end;
    }
    return {};
}

// A multipart body (boundary from `type`) with its parts' order changed: the last part dropped
// (`drop`), or the first two swapped. Unchanged when it has fewer parts than that needs.
std::string reshuffleParts(const std::string& type, const std::string& body, bool drop) {
    const size_t b = type.find("boundary=");
    if (b == std::string::npos) return body;
    std::string boundary = type.substr(b + 9);
    if (const size_t semi = boundary.find(';'); semi != std::string::npos) boundary.resize(semi);
    if (boundary.size() >= 2 && boundary.front() == '"') boundary = boundary.substr(1, boundary.size() - 2);
    const std::string delimiter = "--" + boundary;
    // Each part from its delimiter line to the CRLF before the next delimiter.
    std::vector<std::string> parts;
    size_t at = body.find(delimiter);
    const size_t first = at;
    size_t end = std::string::npos;
    while (at != std::string::npos) {
        const size_t next = body.find("\r\n" + delimiter, at + delimiter.size());
        if (next == std::string::npos) break;
        if (body.compare(at + delimiter.size(), 2, "--") == 0) break; // the closing delimiter
        parts.push_back(body.substr(at, next - at));
        at = next + 2;
        end = at;
    }
    if (first == std::string::npos || end == std::string::npos || parts.size() < 2) return body;
    if (drop)
        parts.pop_back();
    else
        std::swap(parts[0], parts[1]);
    std::string out = body.substr(0, first);
    for (const std::string& p : parts) out += p + "\r\n";
    return out + body.substr(end);
}

} // namespace

std::unique_ptr<FaultProxy> FaultProxy::start(int upstreamPort, std::string* why, const Tls* tls) {
    curl_global_init(CURL_GLOBAL_DEFAULT);
    std::unique_ptr<FaultProxy> p(new FaultProxy());
    p->upstream_ = upstreamPort;
    if (tls) {
        SSL_CTX* ctx = SSL_CTX_new(TLS_server_method());
        p->tls_ = ctx;
        if (!ctx || SSL_CTX_use_certificate_chain_file(ctx, tls->certificate.c_str()) != 1 ||
            SSL_CTX_use_PrivateKey_file(ctx, tls->key.c_str(), SSL_FILETYPE_PEM) != 1) {
            char err[256];
            ERR_error_string_n(ERR_get_error(), err, sizeof err);
            *why = std::string("the proxy cannot load its certificate: ") + err;
            return nullptr;
        }
    }
    p->listen_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (p->listen_ < 0 || ::bind(p->listen_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(p->listen_, 64) != 0 || ::getsockname(p->listen_, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
        *why = std::string("the proxy cannot listen: ") + std::strerror(errno);
        return nullptr;
    }
    p->port_ = ntohs(a.sin_port);
    p->acceptor_ = std::thread([q = p.get()] { q->acceptLoop(); });
    return p;
}

FaultProxy::~FaultProxy() {
    {
        std::lock_guard lock(mutex_); // a held answer checks stop_ under it: no lost wake-up
        stop_.store(true, std::memory_order_release);
    }
    ruleChanged_.notify_all();
    if (acceptor_.joinable()) acceptor_.join();
    if (listen_ >= 0) ::close(listen_);
    std::vector<std::thread> threads;
    {
        std::lock_guard lock(mutex_);
        for (int c : clients_) ::shutdown(c, SHUT_RDWR); // wakes a thread blocked in recv or send
        threads.swap(threads_);
    }
    for (auto& t : threads) t.join();
    if (tls_) SSL_CTX_free(static_cast<SSL_CTX*>(tls_));
}

void FaultProxy::setRule(const Rule& rule) {
    {
        std::lock_guard lock(mutex_);
        rule_ = rule;
        ++ruleSerial_;
    }
    ruleChanged_.notify_all();
}

FaultProxy::Rule FaultProxy::rule() const {
    std::lock_guard lock(mutex_);
    return rule_;
}

void FaultProxy::acceptLoop() {
    // SSL_write to a client that went away raises SIGPIPE; blocked here (and in the serving
    // threads, which inherit this thread's mask) it is EPIPE, and the rest of the test process
    // keeps the default: the engine must survive SIGPIPE on its own (net/http_client.cpp).
    sigset_t pipe;
    sigemptyset(&pipe);
    sigaddset(&pipe, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &pipe, nullptr);
    while (!stop_.load(std::memory_order_acquire)) {
        pollfd pfd{listen_, POLLIN, 0};
        if (::poll(&pfd, 1, 100) <= 0) continue;
        const int c = ::accept4(listen_, nullptr, nullptr, SOCK_CLOEXEC);
        if (c < 0) continue;
        timeval tv{0, 100 * 1000};
        ::setsockopt(c, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
        std::lock_guard lock(mutex_);
        clients_.push_back(c);
        threads_.emplace_back([this, c] { serve(c); });
    }
}

void FaultProxy::serve(int client) {
    Conn conn{client, nullptr};
    bool open = true;
    if (tls_) {
        conn.ssl = SSL_new(static_cast<SSL_CTX*>(tls_));
        SSL_set_fd(conn.ssl, client);
        // The handshake; a client that does not trust the certificate gives up here.
        for (int tries = 0;; ++tries) {
            const int rc = SSL_accept(conn.ssl);
            if (rc == 1) break;
            const int e = SSL_get_error(conn.ssl, rc);
            if ((e != SSL_ERROR_WANT_READ && e != SSL_ERROR_WANT_WRITE) || tries > 100 ||
                stop_.load(std::memory_order_acquire)) {
                open = false;
                break;
            }
        }
    }
    CURL* up = curl_easy_init(); // one upstream connection per client connection, kept alive
    std::string buffer;
    while (open && !stop_.load(std::memory_order_acquire)) {
        const size_t end = buffer.find("\r\n\r\n");
        if (end == std::string::npos) {
            if (buffer.size() > 65536) break;
            char chunk[4096];
            const ssize_t n = conn.read(chunk, sizeof chunk);
            if (n == 0) break;
            if (n < 0) continue; // the receive timeout: look at stop_ again
            buffer.append(chunk, size_t(n));
            continue;
        }
        const std::string head = buffer.substr(0, end + 2);
        buffer.erase(0, end + 4);
        const size_t sp1 = head.find(' '), sp2 = head.find(' ', sp1 + 1);
        if (sp1 == std::string::npos || sp2 == std::string::npos) break;
        const std::string path = head.substr(sp1 + 1, sp2 - sp1 - 1);
        // …/frames/<n> or a list …/frames/<a>,<b>,…: the frames asked for.
        std::vector<int> frames;
        if (const size_t at = path.find("/frames/"); at != std::string::npos) {
            for (size_t i = at + 8; i < path.size();) {
                const int n = std::atoi(path.c_str() + i);
                if (n <= 0) break;
                frames.push_back(n);
                i = path.find(',', i);
                if (i == std::string::npos) break;
                ++i;
            }
        }
        const bool list = frames.size() > 1;
        if (!frames.empty()) {
            requests_.fetch_add(1, std::memory_order_relaxed);
            frames_.fetch_add(int(frames.size()), std::memory_order_relaxed);
            if (list) lists_.fetch_add(1, std::memory_order_relaxed);
        }
        uint64_t serial = 0;
        Rule r;
        {
            std::lock_guard lock(mutex_);
            r = rule_;
            serial = ruleSerial_;
        }
        const auto faultyRule = [&frames, list](const Rule& rule) {
            return rule.fault != Fault::None && !frames.empty() && (list || !rule.listsOnly) &&
                   *std::max_element(frames.begin(), frames.end()) >= rule.fromFrame;
        };
        if (faultyRule(r) && r.fault == Fault::Hold) {
            // Until the test changes the rule (or holdMs): then the new rule decides.
            std::unique_lock lock(mutex_);
            ruleChanged_.wait_for(lock, std::chrono::milliseconds(r.holdMs),
                                  [&] { return ruleSerial_ != serial || stop_.load(std::memory_order_acquire); });
            r = rule_;
        }
        const bool faulty = faultyRule(r);

        long status = 0;
        std::string type, body;
        if (r.fault == Fault::Replace && !r.pathContains.empty() && path.find(r.pathContains) != std::string::npos) {
            status = r.status;
            type = r.type;
            body = r.body;
        } else if (faulty && r.fault == Fault::NotFound) {
            status = 404;
            type = "application/json";
            body = "{\"HttpStatus\": 404, \"Message\": \"Unknown resource\"}";
        } else if (faulty && r.fault == Fault::Unavailable) {
            status = 503;
            type = "text/plain";
            body = "Service Unavailable";
        } else if (faulty && r.fault == Fault::RefuseLists && list) {
            status = 400;
            type = "application/json";
            body = "{\"HttpStatus\": 400, \"Message\": \"Bad request\"}";
        } else {
            const std::string url = "http://127.0.0.1:" + std::to_string(upstream_) + path;
            curl_slist* headers = nullptr;
            for (const char* name : {"accept", "authorization"}) {
                const std::string v = header(head, name);
                if (!v.empty()) headers = curl_slist_append(headers, (std::string(name) + ": " + v).c_str());
            }
            curl_easy_setopt(up, CURLOPT_URL, url.c_str());
            curl_easy_setopt(up, CURLOPT_HTTPHEADER, headers);
            curl_easy_setopt(up, CURLOPT_NOSIGNAL, 1L);
            curl_easy_setopt(up, CURLOPT_TIMEOUT_MS, 30000L);
            curl_easy_setopt(up, CURLOPT_WRITEFUNCTION, &collect);
            curl_easy_setopt(up, CURLOPT_WRITEDATA, &body);
            const CURLcode c = curl_easy_perform(up);
            curl_slist_free_all(headers);
            if (c != CURLE_OK) break; // upstream gone: drop the client's connection too
            char* ct = nullptr;
            curl_easy_getinfo(up, CURLINFO_RESPONSE_CODE, &status);
            curl_easy_getinfo(up, CURLINFO_CONTENT_TYPE, &ct);
            type = ct ? ct : "";
            if (faulty && r.fault == Fault::Truncate) body.resize(body.size() * 2 / 3);
            if (faulty && r.fault == Fault::WrongType) type = "text/html; charset=utf-8";
            if (faulty && list && (r.fault == Fault::DropPart || r.fault == Fault::SwapParts))
                body = reshuffleParts(type, body, r.fault == Fault::DropPart);
        }
        std::string answer = "HTTP/1.1 " + std::to_string(status) +
                             " Proxied\r\nContent-Length: " + std::to_string(body.size()) +
                             "\r\nConnection: keep-alive\r\n";
        if (!type.empty()) answer += "Content-Type: " + type + "\r\n";
        answer += "\r\n";
        if (!conn.write(answer + body)) break;
        if (!frames.empty()) answers_.fetch_add(1, std::memory_order_relaxed);
    }
    curl_easy_cleanup(up);
    if (conn.ssl) SSL_free(conn.ssl);
    std::lock_guard lock(mutex_);
    for (auto it = clients_.begin(); it != clients_.end(); ++it) {
        if (*it == client) {
            clients_.erase(it);
            break;
        }
    }
    ::close(client);
}

} // namespace dicomwebtest
