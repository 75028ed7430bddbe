// HTTP GETs to one server over libcurl's multi interface, driven by one thread of the client's
// own: many requests at once over persistent connections (HTTP/1.1 keep-alive, or HTTP/2
// streams over one connection where the server offers h2 through TLS ALPN).
//
//   * Callers submit requests from any thread (get); each request's callback runs once, on the
//     client's thread, with the answer, a transport error, or Cancelled. Callbacks must be
//     quick and must not wait for other requests (getNow does).
//   * Only URLs of the origin the client was made for (scheme, host, port) are fetched, and
//     redirects are not followed, so credentials never reach another server. They are never
//     put into a message or a log line.
//   * Limits: at most NetworkOptions::maxConnections connections; a connect timeout and a
//     timeout per request; an answer larger than the request's maxBytes is cut off (error).
//
// The thread: submitted requests wait in `incoming_` (under mutex_) until the thread takes them;
// a request with a notBefore time (a retry's back-off) waits in `delayed_` until then; running
// transfers are curl easy handles in the multi handle. The thread sleeps in curl_multi_poll,
// which curl_multi_wakeup (from get, cancelAll and the destructor) interrupts.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "iris/types.h"

namespace iris::net {

// A URL as libcurl's parser splits it.
struct Url {
    std::string scheme;    // "http" or "https"
    std::string host;      // as written ("[::1]" for an IPv6 literal)
    int port = 0;          // the URL's, or the scheme's default
    std::string path;      // from the first '/', without query or fragment
    bool loopback() const; // localhost, 127.0.0.0/8 or ::1
    bool sameOrigin(const Url& other) const {
        return scheme == other.scheme && host == other.host && port == other.port;
    }
    std::string origin() const; // scheme://host:port
};
// InvalidArgument naming the defect: not http(s), no host, credentials in the URL, a query
// (unless `allowQuery`: a QIDO-RS search is one; a series URL is not).
Expected<Url> parseUrl(const std::string& text, bool allowQuery = false);

// A DICOMweb answer whose HTTP status is not 200, as an error saying what it means for `what`
// ("the series", "the study list"); `context` starts the message ("Cannot open X: "). Shared by
// the WADO-RS source and the QIDO-RS client so that both word 401/403/404/5xx alike.
Result httpError(long status, const std::string& context, const std::string& what, bool credentialsGiven);

struct Response {
    Result error;    // no HTTP answer: IoError (refused, reset, TLS), Timeout, Cancelled, CorruptData (too large)
    long status = 0; // the HTTP status, when error is ok
    std::string contentType; // the Content-Type header ("" when absent)
    std::vector<uint8_t> body;
    bool http2 = false;
};

class HttpClient {
public:
    using Callback = std::function<void(Response&&)>;
    using Clock = std::chrono::steady_clock;

    // A client for the origin of `base`; fails for an unreadable CA file.
    static Expected<std::unique_ptr<HttpClient>> create(const NetworkOptions& options, const Url& base);
    // Ends every request (callbacks get Cancelled) and joins the thread.
    ~HttpClient();
    HttpClient(const HttpClient&) = delete;
    HttpClient& operator=(const HttpClient&) = delete;

    // Starts GET `url` (not before `notBefore`) with that Accept header; `done` runs on the
    // client's thread, never inside get(). A URL of another origin is answered with an error.
    void get(std::string url, std::string accept, size_t maxBytes, Callback done, Clock::time_point notBefore = {});
    // get() and wait for its answer. Never from a callback.
    Response getNow(std::string url, std::string accept, size_t maxBytes);
    // Every request submitted so far ends with Cancelled (those on the wire are aborted).
    void cancelAll();
    // Whether an answer came over HTTP/2 (requests are then multiplexed, not limited by connections).
    bool multiplexing() const { return http2_.load(std::memory_order_relaxed); }

private:
    struct Transfer;
    HttpClient(const NetworkOptions& options, Url origin);
    void run();
    void start(std::unique_ptr<Transfer> t);
    void finish(Transfer* t, Response&& r); // removes it and runs its callback
    Response complete(Transfer& t, int curlCode);

    const NetworkOptions options_;
    const Url origin_;
    void* multi_ = nullptr; // CURLM*
    void* share_ = nullptr; // CURLSH*: TLS sessions and DNS shared by every transfer

    std::mutex mutex_; // guards incoming_, cancel_, stop_
    std::vector<std::unique_ptr<Transfer>> incoming_;
    bool cancel_ = false;
    bool stop_ = false;

    // The client's thread only.
    std::vector<std::unique_ptr<Transfer>> delayed_;
    std::vector<std::unique_ptr<Transfer>> running_;

    // Relaxed: a hint for how many requests to keep in flight; a stale value only delays the
    // change by one request.
    std::atomic<bool> http2_{false};
    std::thread thread_;
};

} // namespace iris::net
