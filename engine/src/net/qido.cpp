// iris::dicomweb::QidoClient (iris/dicomweb.h) over net::HttpClient: the query strings and the
// parsing are net/qido_parse (pure, fuzzed); this file sends the searches and checks the
// answers' HTTP status and content type. Thread safety: HttpClient::getNow may be called from
// any thread at once, and everything else here is immutable after create().
#include "iris/dicomweb.h"

#include <algorithm>

#include "net/http_client.h"
#include "net/multipart.h"
#include "net/qido_parse.h"
#include "slide/dicom_json.h"

namespace iris::dicomweb {

namespace {

// Answers larger than this are refused: 1000 studies of DICOM JSON are well under 16 MiB.
constexpr size_t kMaxAnswerBytes = size_t(64) << 20;

} // namespace

struct QidoClient::Impl {
    NetworkOptions options;
    std::string service; // scheme://host:port/prefix
    std::string origin;  // host:port, for messages
    std::unique_ptr<net::HttpClient> http;

    bool credentials() const { return !options.username.empty() || !options.bearerToken.empty(); }

    // GET url, checked: the answer's body, or an error saying what went wrong with `what`.
    Expected<std::vector<uint8_t>> search(const std::string& url, const std::string& what) const {
        const std::string context = "Cannot search " + what + " on " + origin + ": ";
        net::Response r = http->getNow(url, "application/dicom+json", kMaxAnswerBytes);
        if (!r.error.ok()) return Result(r.error.status(), context + r.error.message());
        // 204 No Content: no match (PS3.18 10.6.3.2 allows it beside an empty array).
        if (r.status == 204) return std::vector<uint8_t>{'[', ']'};
        if (r.status == 400) {
            // The server's own reason helps (Orthanc: a JSON object with "Message"); it is the
            // server's text about our query, never our credentials.
            std::string body(r.body.begin(), r.body.begin() + long(std::min<size_t>(r.body.size(), 300)));
            for (char& c : body)
                if (static_cast<unsigned char>(c) < 0x20) c = ' ';
            return Result(Status::InvalidArgument, context + "the server refused the query (HTTP 400 Bad Request)" +
                                                       (body.empty() ? std::string() : ": " + body));
        }
        if (r.status != 200) return net::httpError(r.status, context, "the QIDO-RS service", credentials());
        const auto type = net::parseMediaType(r.contentType);
        if (!type.ok() || (type->type != "application/dicom+json" && type->type != "application/json")) {
            return Result(Status::CorruptData, context + "the server answered with Content-Type '" +
                                                   r.contentType.substr(0, 100) + "', not application/dicom+json");
        }
        return std::move(r.body);
    }
};

QidoClient::QidoClient(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
QidoClient::~QidoClient() = default;

Expected<std::unique_ptr<QidoClient>> QidoClient::create(const std::string& serviceUrl, const NetworkOptions& options) {
    auto url = net::parseUrl(serviceUrl);
    if (!url.ok()) return url.error();
    if (url->scheme == "http" && !url->loopback() && !options.allowPlainHttp) {
        return Result(Status::InvalidArgument,
                      "Cannot search '" + serviceUrl +
                          "': plain http:// is only used for loopback hosts (patient data and credentials would "
                          "cross the network unencrypted); use https://, or set NetworkOptions::allowPlainHttp");
    }
    auto impl = std::make_unique<Impl>();
    impl->options = options;
    std::string path = url->path;
    while (!path.empty() && path.back() == '/') path.pop_back();
    impl->service = url->origin() + path;
    impl->origin = url->host + ":" + std::to_string(url->port);
    auto http = net::HttpClient::create(options, *url);
    if (!http.ok()) return http.error();
    impl->http = std::move(*http);
    return std::unique_ptr<QidoClient>(new QidoClient(std::move(impl)));
}

Expected<Page<Study>> QidoClient::searchStudies(const StudyQuery& query) const {
    auto q = net::qido::studyQueryString(query);
    if (!q.ok()) return q.error();
    const std::string url = impl_->service + "/studies" + *q;
    auto body = impl_->search(url, "studies");
    if (!body.ok()) return body.error();
    auto studies = net::qido::parseStudies(body->data(), body->size(), "The QIDO-RS answer of GET " + url);
    if (!studies.ok()) return studies.error();
    Page<Study> page;
    page.more = studies->size() > query.limit;
    if (page.more) studies->resize(query.limit);
    page.items = std::move(*studies);
    return page;
}

Expected<Page<Series>> QidoClient::searchSeries(const std::string& studyInstanceUid, const SeriesQuery& query) const {
    if (!dicom::isUid(studyInstanceUid)) {
        return Result(Status::InvalidArgument,
                      "Cannot search the series of study '" + studyInstanceUid.substr(0, 80) + "': not a DICOM UID");
    }
    auto q = net::qido::seriesQueryString(query);
    if (!q.ok()) return q.error();
    const std::string url = impl_->service + "/studies/" + studyInstanceUid + "/series" + *q;
    auto body = impl_->search(url, "the series of study " + studyInstanceUid);
    if (!body.ok()) return body.error();
    auto series =
        net::qido::parseSeries(body->data(), body->size(), studyInstanceUid, "The QIDO-RS answer of GET " + url);
    if (!series.ok()) return series.error();
    Page<Series> page;
    page.more = series->size() > query.limit;
    if (page.more) series->resize(query.limit);
    page.items = std::move(*series);
    return page;
}

std::string QidoClient::seriesUrl(const std::string& studyInstanceUid, const std::string& seriesInstanceUid) const {
    return impl_->service + "/studies/" + studyInstanceUid + "/series/" + seriesInstanceUid;
}

const std::string& QidoClient::serviceUrl() const { return impl_->service; }

} // namespace iris::dicomweb
