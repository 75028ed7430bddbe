#include "net/http_client.h"
#include "core/thread_name.h"

#include <pthread.h>
#include <signal.h>

#include <curl/curl.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <future>

namespace iris::net {

namespace {

void initCurlOnce() {
    static std::once_flag once;
    std::call_once(once, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
}

std::string urlPart(CURLU* u, CURLUPart part, unsigned flags = 0) {
    char* s = nullptr;
    if (curl_url_get(u, part, &s, flags) != CURLUE_OK || !s) return {};
    std::string out(s);
    curl_free(s);
    return out;
}

std::string reason(long status) {
    switch (status) {
    case 400: return "Bad Request";
    case 401: return "Unauthorized";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 406: return "Not Acceptable";
    case 408: return "Request Timeout";
    case 429: return "Too Many Requests";
    case 500: return "Internal Server Error";
    case 502: return "Bad Gateway";
    case 503: return "Service Unavailable";
    case 504: return "Gateway Timeout";
    default: return {};
    }
}

} // namespace

Result httpError(long status, const std::string& context, const std::string& what, bool credentialsGiven) {
    std::string code = "HTTP ";
    code.append(std::to_string(status));
    if (const std::string r = reason(status); !r.empty()) code.append(1, ' ').append(r);
    if (status == 401) {
        return Result(Status::IoError,
                      context + (credentialsGiven
                                     ? "the server refused the credentials given (" + code + ")"
                                     : "the server asks for credentials (" + code + "); give them in NetworkOptions"));
    }
    if (status == 403)
        return Result(Status::IoError, context + "the server refuses access to " + what + " (" + code + ")");
    if (status == 404) return Result(Status::NotFound, context + what + " is not on the server (" + code + ")");
    if (status == 408 || status == 429 || (status >= 500 && status <= 599))
        return Result(Status::IoError, context + "the server failed (" + code + ")");
    if (status >= 300 && status <= 399)
        return Result(Status::IoError, context + "the server redirects (" + code + "), which is not followed");
    return Result(Status::CorruptData, context + "the server answered " + code + " for " + what);
}

bool Url::loopback() const {
    if (host == "localhost" || host == "[::1]") return true;
    // 127.0.0.0/8, written as a dotted quad (curl normalises other IPv4 spellings to it).
    unsigned a = 0, b = 0, c = 0, d = 0;
    char tail = 0;
    return std::sscanf(host.c_str(), "%u.%u.%u.%u%c", &a, &b, &c, &d, &tail) == 4 && a == 127 && b < 256 && c < 256 &&
           d < 256;
}

std::string Url::origin() const { return scheme + "://" + host + ":" + std::to_string(port); }

Expected<Url> parseUrl(const std::string& text, bool allowQuery) {
    initCurlOnce();
    const auto bad = [&](const std::string& why) {
        // The text may hold credentials: name only what comes after them.
        const size_t at = text.find('@');
        const std::string shown = at == std::string::npos ? text : "…" + text.substr(at);
        return Result(Status::InvalidArgument, "'" + shown + "' is not a usable DICOMweb URL: " + why);
    };
    CURLU* u = curl_url();
    if (!u) return Result(Status::OutOfMemory, "libcurl could not allocate a URL");
    const CURLUcode rc = curl_url_set(u, CURLUPART_URL, text.c_str(), 0);
    Url url;
    std::string user, query, port;
    if (rc == CURLUE_OK) {
        url.scheme = urlPart(u, CURLUPART_SCHEME);
        url.host = urlPart(u, CURLUPART_HOST);
        port = urlPart(u, CURLUPART_PORT, CURLU_DEFAULT_PORT);
        url.path = urlPart(u, CURLUPART_PATH);
        user = urlPart(u, CURLUPART_USER);
        query = urlPart(u, CURLUPART_QUERY);
    }
    curl_url_cleanup(u);
    if (rc != CURLUE_OK) return bad(curl_url_strerror(rc));
    for (char& c : url.scheme) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (url.scheme != "http" && url.scheme != "https") return bad("the scheme must be http or https");
    if (url.host.empty()) return bad("it names no host");
    if (!user.empty()) {
        return bad("credentials in the URL are not accepted (they would end up in logs and recent-file lists); "
                   "give them in NetworkOptions");
    }
    if (!query.empty() && !allowQuery) return bad("a query (?…) is not part of a series URL");
    url.port = std::atoi(port.c_str());
    if (url.port <= 0 || url.port > 65535) return bad("no valid port");
    return url;
}

struct HttpClient::Transfer {
    std::string url;
    std::string accept;
    size_t maxBytes = 0;
    Callback done;
    Clock::time_point notBefore{};
    CURL* easy = nullptr;
    curl_slist* headers = nullptr;
    std::vector<uint8_t> body;
    bool overflow = false;
    Result refused; // not fetched: answered with this on the client's thread (callbacks never run inside get)
    char errbuf[CURL_ERROR_SIZE] = {};

    ~Transfer() {
        if (easy) curl_easy_cleanup(easy);
        if (headers) curl_slist_free_all(headers);
    }
    static size_t write(char* data, size_t size, size_t n, void* self) {
        auto* t = static_cast<Transfer*>(self);
        const size_t bytes = size * n;
        if (t->body.size() + bytes > t->maxBytes) {
            t->overflow = true;
            return 0; // curl aborts with CURLE_WRITE_ERROR
        }
        t->body.insert(t->body.end(), data, data + bytes);
        return bytes;
    }
};

Expected<std::unique_ptr<HttpClient>> HttpClient::create(const NetworkOptions& options, const Url& base) {
    initCurlOnce();
    if (!options.caFile.empty()) {
        std::FILE* f = std::fopen(options.caFile.c_str(), "rb");
        if (!f) {
            return Result(Status::NotFound,
                          "The CA file '" + options.caFile + "' cannot be read: " + std::strerror(errno));
        }
        std::fclose(f);
    }
    std::unique_ptr<HttpClient> c(new HttpClient(options, base));
    if (!c->multi_ || !c->share_) return Result(Status::OutOfMemory, "libcurl could not make a multi handle");
    c->thread_ = std::thread([p = c.get()] {
        nameThisThread("iris-http");
        p->run();
    });
    return c;
}

HttpClient::HttpClient(const NetworkOptions& options, Url origin) : options_(options), origin_(std::move(origin)) {
    CURLM* multi = curl_multi_init();
    CURLSH* share = curl_share_init();
    if (multi) {
        const long connections = long(std::max<uint32_t>(1, options_.maxConnections));
        curl_multi_setopt(multi, CURLMOPT_MAX_HOST_CONNECTIONS, connections);
        curl_multi_setopt(multi, CURLMOPT_MAX_TOTAL_CONNECTIONS, connections);
        curl_multi_setopt(multi, CURLMOPT_MAXCONNECTS, connections);
        curl_multi_setopt(multi, CURLMOPT_PIPELINING, long(CURLPIPE_MULTIPLEX));
    }
    if (share) {
        // Every transfer runs on the client's thread, so the share needs no lock callbacks.
        curl_share_setopt(share, CURLSHOPT_SHARE, CURL_LOCK_DATA_SSL_SESSION);
        curl_share_setopt(share, CURLSHOPT_SHARE, CURL_LOCK_DATA_DNS);
    }
    multi_ = multi;
    share_ = share;
}

HttpClient::~HttpClient() {
    {
        // Under the lock: the thread frees the multi handle under it once it has seen stop_.
        std::lock_guard lock(mutex_);
        stop_ = true;
        if (multi_) curl_multi_wakeup(static_cast<CURLM*>(multi_));
    }
    if (thread_.joinable()) thread_.join();
    if (multi_) curl_multi_cleanup(static_cast<CURLM*>(multi_)); // the thread never ran
    if (share_) curl_share_cleanup(static_cast<CURLSH*>(share_));
}

void HttpClient::get(std::string url, std::string accept, size_t maxBytes, Callback done, Clock::time_point notBefore) {
    auto t = std::make_unique<Transfer>();
    auto parsed = parseUrl(url, /*allowQuery=*/true); // a QIDO-RS search; the origin check below still holds
    if (!parsed.ok()) {
        t->refused = parsed.error();
    } else if (!parsed->sameOrigin(origin_)) {
        t->refused = Result(Status::InvalidArgument, "Refusing to fetch '" + parsed->origin() + parsed->path +
                                                         "': it is not on the series' server " + origin_.origin());
    }
    t->url = std::move(url);
    t->accept = std::move(accept);
    t->maxBytes = maxBytes;
    t->done = std::move(done);
    t->notBefore = notBefore;
    {
        std::lock_guard lock(mutex_);
        incoming_.push_back(std::move(t));
    }
    curl_multi_wakeup(static_cast<CURLM*>(multi_));
}

Response HttpClient::getNow(std::string url, std::string accept, size_t maxBytes) {
    std::promise<Response> promise;
    std::future<Response> answer = promise.get_future();
    get(std::move(url), std::move(accept), maxBytes, [&promise](Response&& r) { promise.set_value(std::move(r)); });
    return answer.get(); // every request's callback runs exactly once, cancelled or not
}

void HttpClient::cancelAll() {
    {
        std::lock_guard lock(mutex_);
        cancel_ = true;
    }
    curl_multi_wakeup(static_cast<CURLM*>(multi_));
}

void HttpClient::start(std::unique_ptr<Transfer> t) {
    if (!t->refused.ok()) {
        Response r;
        r.error = t->refused;
        t->done(std::move(r));
        return;
    }
    CURL* e = curl_easy_init();
    if (!e) {
        Response r;
        r.error = Result(Status::OutOfMemory, "libcurl could not make a transfer");
        t->done(std::move(r));
        return;
    }
    t->easy = e;
    t->headers = curl_slist_append(nullptr, ("Accept: " + t->accept).c_str());
    curl_easy_setopt(e, CURLOPT_URL, t->url.c_str());
    curl_easy_setopt(e, CURLOPT_PROTOCOLS_STR, "http,https");
    curl_easy_setopt(e, CURLOPT_FOLLOWLOCATION, 0L); // a redirect must not carry credentials elsewhere
    curl_easy_setopt(e, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(e, CURLOPT_HTTPHEADER, t->headers);
    curl_easy_setopt(e, CURLOPT_ACCEPT_ENCODING, ""); // whatever libcurl decodes (gzip for DICOM JSON)
    curl_easy_setopt(e, CURLOPT_USERAGENT, "IrisView");
    curl_easy_setopt(e, CURLOPT_CONNECTTIMEOUT_MS, long(options_.connectTimeoutMs));
    curl_easy_setopt(e, CURLOPT_TIMEOUT_MS, long(options_.requestTimeoutMs));
    curl_easy_setopt(e, CURLOPT_HTTP_VERSION, long(CURL_HTTP_VERSION_2TLS));
    curl_easy_setopt(e, CURLOPT_PIPEWAIT, 1L); // wait for an HTTP/2 connection rather than open another
    curl_easy_setopt(e, CURLOPT_SSL_VERIFYPEER, options_.verifyTls ? 1L : 0L);
    curl_easy_setopt(e, CURLOPT_SSL_VERIFYHOST, options_.verifyTls ? 2L : 0L);
    if (!options_.caFile.empty()) curl_easy_setopt(e, CURLOPT_CAINFO, options_.caFile.c_str());
    if (!options_.bearerToken.empty()) {
        curl_easy_setopt(e, CURLOPT_HTTPAUTH, long(CURLAUTH_BEARER));
        curl_easy_setopt(e, CURLOPT_XOAUTH2_BEARER, options_.bearerToken.c_str());
    } else if (!options_.username.empty()) {
        curl_easy_setopt(e, CURLOPT_HTTPAUTH, long(CURLAUTH_BASIC)); // sent with the first request
        curl_easy_setopt(e, CURLOPT_USERNAME, options_.username.c_str());
        curl_easy_setopt(e, CURLOPT_PASSWORD, options_.password.c_str());
    }
    curl_easy_setopt(e, CURLOPT_SHARE, static_cast<CURLSH*>(share_));
    curl_easy_setopt(e, CURLOPT_WRITEFUNCTION, &Transfer::write);
    curl_easy_setopt(e, CURLOPT_WRITEDATA, t.get());
    curl_easy_setopt(e, CURLOPT_ERRORBUFFER, t->errbuf);
    curl_easy_setopt(e, CURLOPT_PRIVATE, t.get());
    if (curl_multi_add_handle(static_cast<CURLM*>(multi_), e) != CURLM_OK) {
        Response r;
        r.error = Result(Status::IoError, "libcurl refused a transfer to " + origin_.origin());
        t->done(std::move(r));
        return;
    }
    running_.push_back(std::move(t));
}

Response HttpClient::complete(Transfer& t, int curlCode) {
    Response r;
    const auto code = CURLcode(curlCode);
    if (code == CURLE_OK) {
        long status = 0;
        curl_easy_getinfo(t.easy, CURLINFO_RESPONSE_CODE, &status);
        char* type = nullptr;
        curl_easy_getinfo(t.easy, CURLINFO_CONTENT_TYPE, &type);
        long version = 0;
        curl_easy_getinfo(t.easy, CURLINFO_HTTP_VERSION, &version);
        r.status = status;
        r.contentType = type ? type : "";
        r.body = std::move(t.body);
        r.http2 = version == CURL_HTTP_VERSION_2_0;
        if (r.http2) http2_.store(true, std::memory_order_relaxed);
        return r;
    }
    // The URL is ours (no credentials in it); the detail is libcurl's.
    const std::string where = "Cannot fetch " + t.url + ": ";
    const std::string detail = t.errbuf[0] ? std::string(t.errbuf) : std::string(curl_easy_strerror(code));
    switch (code) {
    case CURLE_OPERATION_TIMEDOUT: r.error = Result(Status::Timeout, where + "timed out (" + detail + ")"); break;
    case CURLE_WRITE_ERROR:
        if (t.overflow) {
            r.error = Result(Status::CorruptData,
                             where + "the answer is larger than " + std::to_string(t.maxBytes) + " bytes");
            break;
        }
        [[fallthrough]];
    default: r.error = Result(Status::IoError, where + detail); break;
    case CURLE_PEER_FAILED_VERIFICATION:
    case CURLE_SSL_CACERT_BADFILE:
    case CURLE_SSL_CERTPROBLEM:
    case CURLE_SSL_CONNECT_ERROR:
        r.error = Result(Status::IoError, where +
                                              "TLS failed, the server's certificate is not trusted or the "
                                              "connection is not TLS (" +
                                              detail + ")");
        break;
    }
    return r;
}

void HttpClient::finish(Transfer* t, Response&& r) {
    auto it = std::find_if(running_.begin(), running_.end(), [&](const auto& p) { return p.get() == t; });
    if (it == running_.end()) return;
    std::unique_ptr<Transfer> owned = std::move(*it);
    running_.erase(it);
    curl_multi_remove_handle(static_cast<CURLM*>(multi_), owned->easy);
    owned->done(std::move(r));
}

void HttpClient::run() {
    // A write to a connection the server has closed raises SIGPIPE, whose default action ends
    // the process: the host application, a viewer in a hospital. libcurl's own guard
    // (ignoring it process-wide around each call) is off with CURLOPT_NOSIGNAL, which threads
    // need, and OpenSSL writes to its socket with write(). Every transfer runs on this thread,
    // so blocking the signal here turns it into EPIPE for this thread alone (the pending
    // signal is discarded when the thread ends) and leaves the host's handling alone.
    sigset_t pipe;
    sigemptyset(&pipe);
    sigaddset(&pipe, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &pipe, nullptr);
    CURLM* multi = static_cast<CURLM*>(multi_);
    for (;;) {
        std::vector<std::unique_ptr<Transfer>> fresh;
        bool cancel = false, stop = false;
        {
            std::lock_guard lock(mutex_);
            fresh.swap(incoming_);
            cancel = cancel_;
            cancel_ = false;
            stop = stop_;
        }
        for (auto& t : fresh) delayed_.push_back(std::move(t));
        if (cancel || stop) {
            // Everything submitted until now ends: queued and delayed requests, and transfers on
            // the wire (removing a handle aborts its transfer).
            const auto cancelled = [] {
                Response r;
                r.error = Result(Status::Cancelled, "The request was cancelled");
                return r;
            };
            std::vector<std::unique_ptr<Transfer>> waiting;
            waiting.swap(delayed_);
            for (auto& t : waiting) t->done(cancelled());
            while (!running_.empty()) finish(running_.back().get(), cancelled());
        }
        if (stop) {
            // The connections close here too (TLS sends its close_notify: a write), on this
            // thread, where SIGPIPE is blocked. Under the lock: the destructor may be waking it.
            std::lock_guard lock(mutex_);
            curl_multi_cleanup(multi);
            multi_ = nullptr;
            return;
        }
        const Clock::time_point now = Clock::now();
        Clock::time_point next = now + std::chrono::seconds(1);
        for (size_t i = 0; i < delayed_.size();) {
            if (delayed_[i]->notBefore <= now) {
                std::unique_ptr<Transfer> t = std::move(delayed_[i]);
                delayed_.erase(delayed_.begin() + long(i));
                start(std::move(t));
            } else {
                next = std::min(next, delayed_[i]->notBefore);
                ++i;
            }
        }
        int active = 0;
        curl_multi_perform(multi, &active);
        int queued = 0;
        while (CURLMsg* msg = curl_multi_info_read(multi, &queued)) {
            if (msg->msg != CURLMSG_DONE) continue;
            Transfer* t = nullptr;
            curl_easy_getinfo(msg->easy_handle, CURLINFO_PRIVATE, &t);
            const CURLcode code = msg->data.result;
            if (t) finish(t, complete(*t, int(code)));
        }
        const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(next - Clock::now()).count();
        curl_multi_poll(multi, nullptr, 0, int(std::clamp<long long>(wait, 0, 1000)), nullptr);
    }
}

} // namespace iris::net
