// QIDO-RS (iris/dicomweb.h, net/qido*) against a real Orthanc with its DICOMweb plugin started
// by the suite on 127.0.0.1 (orthanc_server.h), holding eight studies made from the dicom-boxes
// series (qido_studies.h): seven of modality SM, one OT.
//   * the query strings and the answer parser alone: encoding as Orthanc reads it, refused
//     queries, malformed answers named by element and field;
//   * searches: matching fields, wildcards, no match, a date range, paging over more results
//     than a page (with and without the SM filter, where Orthanc applies limit before offset),
//     the series of a study, and the series URL opened by the DICOMweb source;
//   * basic authentication: a wrong or missing password is a clear 401 error;
//   * a lying server (fault_proxy.h): garbage, a non-array, a missing UID, a bad count, a wrong
//     content type, a 500, a series of another study — each a clear error;
//   * the Engine: open() of a protected series fails until setNetworkOptions() gives the
//     credentials, then renders.
// Every wait is bounded (NetworkOptions' timeouts, waitForFrame's); nothing sleeps.
#include <QtTest>

#include <set>

#include <iris/dicomweb.h>
#include <iris/engine.h>

#include "fault_proxy.h"
#include "net/qido_parse.h"
#include "orthanc_server.h"
#include "qido_studies.h"
#include "slide/slide_source.h"
#include "test_support.h"

using namespace iristest;
using namespace dicomwebtest;
namespace dw = iris::dicomweb;

namespace {

constexpr const char* kUser = "iris";
constexpr const char* kPassword = "s3cret-Pa55";

fs::path outDir() {
    const fs::path d = testOutDir() / "dicomweb-qido";
    fs::create_directories(d);
    return d;
}

bool contains(const std::string& s, const std::string& w) { return s.find(w) != std::string::npos; }

// The error holds every one of `words`, has `status`, and never the password.
void expectError(const iris::Result& r, iris::Status status, std::initializer_list<std::string> words) {
    QVERIFY2(!r.ok(), "succeeded");
    qInfo("%s", describe(r).c_str());
    QVERIFY2(r.status() == status, ("status " + std::string(iris::statusName(r.status())) + ", expected " +
                                    iris::statusName(status) + ": " + r.message())
                                       .c_str());
    for (const std::string& w : words)
        QVERIFY2(contains(r.message(), w), ("the message does not say '" + w + "': " + r.message()).c_str());
    QVERIFY2(!contains(r.message(), kPassword), "the message shows the password");
}

std::unique_ptr<dw::QidoClient> client(const std::string& root, const iris::NetworkOptions& o = {}) {
    auto c = dw::QidoClient::create(root, o);
    if (!c.ok()) {
        qWarning("%s", describe(c.error()).c_str());
        return nullptr;
    }
    return std::move(*c);
}

std::vector<uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }

iris::Result parseStudiesError(const std::string& json) {
    const auto b = bytes(json);
    auto r = iris::net::qido::parseStudies(b.data(), b.size(), "answer");
    return r.ok() ? iris::Result() : r.error();
}

} // namespace

class TestQido : public QObject {
    Q_OBJECT

    std::unique_ptr<OrthancServer> server_;  // plain http, no authentication: the eight studies
    std::unique_ptr<OrthancServer> secured_; // basic authentication: study 1
    std::vector<MadeStudy> studies_;
    MadeStudy securedStudy_;

    std::set<std::string> uidsOf(const std::vector<dw::Study>& s) {
        std::set<std::string> out;
        for (const auto& x : s) out.insert(x.studyInstanceUid);
        return out;
    }
    std::set<std::string> expectedUids(const std::function<bool(const StudySpec&)>& pick) {
        std::set<std::string> out;
        for (const auto& m : studies_)
            if (pick(m.spec)) out.insert(m.studyUid);
        return out;
    }
    // Every study matching `q`, page after page; checks that pages are full but the last.
    std::vector<dw::Study> allPages(const dw::QidoClient& c, dw::StudyQuery q, int* pages) {
        std::vector<dw::Study> all;
        *pages = 0;
        for (q.offset = 0;; q.offset += q.limit) {
            auto page = c.searchStudies(q);
            if (!page.ok()) {
                qWarning("%s", describe(page.error()).c_str());
                return {};
            }
            ++*pages;
            all.insert(all.end(), page->items.begin(), page->items.end());
            if (!page->more) break;
            if (page->items.size() != q.limit || *pages > 20) {
                qWarning("a page before the last holds %zu results", page->items.size());
                return {};
            }
        }
        return all;
    }

private slots:
    void initTestCase() {
        if (std::system("command -v Orthanc > /dev/null 2>&1") != 0)
            QFAIL("Orthanc (Debian orthanc, orthanc-dicomweb) is not installed: scripts/install-deps.sh installs it");
        auto boxes = slidesDir("unsupported/dicom-boxes");
        if (!boxes) QSKIP("no test data");
        std::string why;
        const std::vector<StudySpec> specs = standardStudies();
        for (size_t i = 0; i < specs.size(); ++i) {
            MadeStudy m;
            QVERIFY2(makeStudy(*boxes, outDir() / ("study-" + std::to_string(i + 1)), specs[i], &m, &why), why.c_str());
            studies_.push_back(m);
        }
        server_ = OrthancServer::start(outDir() / "orthanc", {}, &why);
        QVERIFY2(server_, why.c_str());
        for (const auto& m : studies_) QVERIFY2(server_->upload(m.folder, &why), why.c_str());
        secured_ = OrthancServer::start(outDir() / "orthanc-auth", {kUser, kPassword}, &why);
        QVERIFY2(secured_, why.c_str());
        QVERIFY2(makeStudy(*boxes, outDir() / "secured-study", specs[0], &securedStudy_, &why), why.c_str());
        QVERIFY2(secured_->upload(securedStudy_.folder, &why), why.c_str());
    }
    void cleanupTestCase() {
        if (server_) QVERIFY(server_->stop());
        if (secured_) QVERIFY(secured_->stop());
    }

    // --- pure: query strings and answers ------------------------------------------------
    void queryStrings() {
        using iris::net::qido::encodeValue;
        QCOMPARE(QString::fromStdString(*encodeValue("PatientName", "Doe^J*n?")), QStringLiteral("Doe^J*n?"));
        QCOMPARE(QString::fromStdString(*encodeValue("StudyDescription", "Slide study 3")),
                 QStringLiteral("Slide?study?3"));
        QCOMPARE(QString::fromStdString(*encodeValue("PatientName", "M\xC3\xBCller&x=1")),
                 QStringLiteral("M%C3%BCller%26x%3D1"));
        expectError(encodeValue("PatientID", std::string("P\n1")).error(), iris::Status::InvalidArgument,
                    {"PatientID", "control character"});

        dw::StudyQuery q;
        q.patientName = "Doe^Jane*";
        q.limit = 3;
        q.offset = 6;
        // With the SM filter, limit counts from 0 (Orthanc's quirk): offset + limit + 1.
        QVERIFY(contains(*iris::net::qido::studyQueryString(q), "&limit=10&offset=6"));
        q.modality.clear();
        QVERIFY(contains(*iris::net::qido::studyQueryString(q), "&limit=4&offset=6"));
        q.studyDateFrom = "2024-01-01";
        expectError(iris::net::qido::studyQueryString(q).error(), iris::Status::InvalidArgument,
                    {"StudyDate from", "YYYYMMDD"});
        q.studyDateFrom = "20240105";
        q.studyDateTo = "20240101";
        expectError(iris::net::qido::studyQueryString(q).error(), iris::Status::InvalidArgument, {"ends before"});
        q.studyDateTo.clear();
        QVERIFY(contains(*iris::net::qido::studyQueryString(q), "StudyDate=20240105-&"));
        q.limit = 0;
        expectError(iris::net::qido::studyQueryString(q).error(), iris::Status::InvalidArgument, {"1 to 1000"});
    }

    void malformedAnswers() {
        using S = iris::Status;
        expectError(parseStudiesError(""), S::CorruptData, {"answer is empty"});
        expectError(parseStudiesError("<html>Bad gateway</html>"), S::CorruptData, {"is not valid JSON"});
        expectError(parseStudiesError("{\"0020000D\": {}}"), S::CorruptData, {"is not a JSON array"});
        expectError(parseStudiesError(std::string(100, '[') + std::string(100, ']')), S::CorruptData,
                    {"nested deeper than 64"});
        expectError(parseStudiesError("[42]"), S::CorruptData, {"element 1 is not a DICOM JSON object"});
        expectError(parseStudiesError("[{\"00100010\": {\"vr\": \"PN\", \"Value\": [{\"Alphabetic\": \"X\"}]}}]"),
                    S::CorruptData, {"element 1", "has no StudyInstanceUID (0020,000D)"});
        expectError(parseStudiesError("[{\"0020000D\": {\"vr\": \"UI\", \"Value\": [\"1.2.3\"]}}, "
                                      "{\"0020000D\": {\"vr\": \"UI\", \"Value\": [\"1.2.x\"]}}]"),
                    S::CorruptData, {"element 2", "StudyInstanceUID (0020,000D) is '1.2.x', not a DICOM UID"});
        expectError(parseStudiesError("[{\"0020000D\": {\"vr\": \"UI\", \"Value\": [\"1.2.3\"]}, "
                                      "\"00201206\": {\"vr\": \"IS\", \"Value\": [\"many\"]}}]"),
                    S::CorruptData, {"NumberOfStudyRelatedSeries (0020,1206) is 'many', not an integer"});
        const auto b = bytes("[{\"0020000D\": {\"vr\": \"UI\", \"Value\": [\"1.2.4\"]}, "
                             "\"0020000E\": {\"vr\": \"UI\", \"Value\": [\"1.2.5\"]}}]");
        auto s = iris::net::qido::parseSeries(b.data(), b.size(), "1.2.3", "answer");
        expectError(s.ok() ? iris::Result() : s.error(), S::CorruptData,
                    {"element 1", "series of study '1.2.4', not of the study asked for (1.2.3)"});
        // A Series Number may be negative (IS); a count may not.
        const auto negative = bytes("[{\"0020000E\": {\"vr\": \"UI\", \"Value\": [\"1.2.5\"]}, "
                                    "\"00200011\": {\"vr\": \"IS\", \"Value\": [-2]}}]");
        auto numbered = iris::net::qido::parseSeries(negative.data(), negative.size(), "1.2.3", "answer");
        QVERIFY(numbered.ok());
        QCOMPARE((*numbered)[0].seriesNumber, int64_t(-2));
        QCOMPARE((*numbered)[0].numberOfInstances, int64_t(-1));
        // A well-formed answer: every field read, absent counts as -1.
        const auto good =
            bytes("[{\"0020000D\": {\"vr\": \"UI\", \"Value\": [\"1.2.3\"]}, \"00100010\": {\"vr\": \"PN\", \"Value\": "
                  "[{\"Alphabetic\": \"Doe^Jane\"}]}, \"00080061\": {\"vr\": \"CS\", \"Value\": [\"SM\", \"OT\"]}, "
                  "\"00201208\": {\"vr\": \"IS\", \"Value\": [2]}}]");
        auto studies = iris::net::qido::parseStudies(good.data(), good.size(), "answer");
        QVERIFY2(studies.ok(), describe(studies.ok() ? iris::Result() : studies.error()).c_str());
        QCOMPARE(studies->size(), size_t(1));
        QCOMPARE(QString::fromStdString((*studies)[0].patientName), QStringLiteral("Doe^Jane"));
        QCOMPARE((*studies)[0].modalities, (std::vector<std::string>{"SM", "OT"}));
        QCOMPARE((*studies)[0].numberOfInstances, int64_t(2));
        QCOMPARE((*studies)[0].numberOfSeries, int64_t(-1));
    }

    // --- against Orthanc --------------------------------------------------------------------
    void matching() {
        auto c = client(server_->dicomWebRoot() + "/"); // a trailing '/' is ignored
        QVERIFY(c);
        QCOMPARE(QString::fromStdString(c->serviceUrl()), QString::fromStdString(server_->dicomWebRoot()));
        dw::StudyQuery q;
        q.patientId = "PID3";
        auto r = c->searchStudies(q);
        QVERIFY2(r.ok(), describe(r.ok() ? iris::Result() : r.error()).c_str());
        QCOMPARE(r->items.size(), size_t(1));
        QVERIFY(!r->more);
        const dw::Study& s = r->items[0];
        const MadeStudy& m = studies_[2];
        QCOMPARE(s.studyInstanceUid, m.studyUid);
        QCOMPARE(s.patientName, std::string("Doe^Jane3"));
        QCOMPARE(s.patientId, std::string("PID3"));
        QCOMPARE(s.accessionNumber, std::string("ACC-3"));
        QCOMPARE(s.studyDate, std::string("20240103"));
        QCOMPARE(s.studyDescription, std::string("Slide study 3"));
        QCOMPARE(s.modalities, std::vector<std::string>{"SM"});
        QCOMPARE(s.numberOfSeries, int64_t(1));
        QCOMPARE(s.numberOfInstances, int64_t(2));
        q = {};
        q.accessionNumber = "ACC-7";
        r = c->searchStudies(q);
        QVERIFY(r.ok());
        QCOMPARE(uidsOf(r->items), std::set<std::string>{studies_[6].studyUid});
        // A description with spaces (sent as '?', Orthanc does not percent-decode).
        q = {};
        q.studyDescription = "Slide study 5";
        r = c->searchStudies(q);
        QVERIFY(r.ok());
        QCOMPARE(uidsOf(r->items), std::set<std::string>{studies_[4].studyUid});
    }

    void wildcards() {
        auto c = client(server_->dicomWebRoot());
        QVERIFY(c);
        const auto check = [&](const std::string& name, const std::string& modality,
                               const std::function<bool(const StudySpec&)>& pick) {
            dw::StudyQuery q;
            q.patientName = name;
            q.modality = modality;
            auto r = c->searchStudies(q);
            QVERIFY2(r.ok(), describe(r.ok() ? iris::Result() : r.error()).c_str());
            QCOMPARE(uidsOf(r->items), expectedUids(pick));
        };
        check("Doe^Jane*", "SM", [](const StudySpec& s) { return s.patientName.rfind("Doe^Jane", 0) == 0; });
        if (QTest::currentTestFailed()) return;
        check("doe*", "", [](const StudySpec& s) { return s.patientName.rfind("Doe", 0) == 0; }); // 6, OT too
        if (QTest::currentTestFailed()) return;
        check("doe*", "SM", [](const StudySpec& s) { return s.patientName.rfind("Doe^Jane", 0) == 0; });
        if (QTest::currentTestFailed()) return;
        check("Roe^Max?", "SM", [](const StudySpec& s) { return s.patientName.rfind("Roe", 0) == 0; });
        if (QTest::currentTestFailed()) return;
        check("*John*", "", [](const StudySpec& s) { return s.modality == "OT"; });
    }

    void noMatch() {
        auto c = client(server_->dicomWebRoot());
        QVERIFY(c);
        dw::StudyQuery q;
        q.patientName = "Nobody^Here*";
        auto r = c->searchStudies(q);
        QVERIFY(r.ok());
        QVERIFY(r->items.empty());
        QVERIFY(!r->more);
        // The OT study is not a slide study.
        q = {};
        q.patientId = "PID8";
        r = c->searchStudies(q);
        QVERIFY(r.ok());
        QVERIFY(r->items.empty());
        // An unknown study has no series.
        auto s = c->searchSeries("1.2.3.4.5");
        QVERIFY(s.ok());
        QVERIFY(s->items.empty());
    }

    void dateRange() {
        auto c = client(server_->dicomWebRoot());
        QVERIFY(c);
        dw::StudyQuery q;
        q.studyDateFrom = "20240102";
        q.studyDateTo = "20240104";
        auto r = c->searchStudies(q);
        QVERIFY(r.ok());
        QCOMPARE(uidsOf(r->items), expectedUids([](const StudySpec& s) {
                     return s.studyDate >= "20240102" && s.studyDate <= "20240104";
                 }));
        q.studyDateFrom = "20240106";
        q.studyDateTo.clear();
        r = c->searchStudies(q);
        QVERIFY(r.ok());
        QCOMPARE(uidsOf(r->items),
                 expectedUids([](const StudySpec& s) { return s.studyDate >= "20240106" && s.modality == "SM"; }));
    }

    // Pages of 3 over 7 SM studies (3, 3, 1) and over all 8 (3, 3, 2): every study once.
    void paging() {
        auto c = client(server_->dicomWebRoot());
        QVERIFY(c);
        for (const std::string modality : {"SM", ""}) {
            dw::StudyQuery q;
            q.modality = modality;
            q.limit = 3;
            int pages = 0;
            const std::vector<dw::Study> all = allPages(*c, q, &pages);
            const std::set<std::string> want =
                expectedUids([&](const StudySpec& s) { return modality.empty() || s.modality == modality; });
            qInfo("modality '%s': %zu studies in %d pages", modality.c_str(), all.size(), pages);
            QCOMPARE(all.size(), want.size()); // none twice
            QCOMPARE(uidsOf(all), want);
            QCOMPARE(pages, 3);
        }
        // A page past the end is empty.
        dw::StudyQuery q;
        q.limit = 3;
        q.offset = 30;
        auto r = c->searchStudies(q);
        QVERIFY(r.ok());
        QVERIFY(r->items.empty());
        QVERIFY(!r->more);
    }

    void seriesOfStudy() {
        auto c = client(server_->dicomWebRoot());
        QVERIFY(c);
        const MadeStudy& m = studies_[1];
        auto s = c->searchSeries(m.studyUid);
        QVERIFY2(s.ok(), describe(s.ok() ? iris::Result() : s.error()).c_str());
        QCOMPARE(s->items.size(), size_t(1));
        const dw::Series& x = s->items[0];
        QCOMPARE(x.seriesInstanceUid, m.seriesUid);
        QCOMPARE(x.studyInstanceUid, m.studyUid);
        QCOMPARE(x.modality, std::string("SM"));
        QCOMPARE(x.seriesDescription, std::string("Slide 2"));
        QCOMPARE(x.numberOfInstances, int64_t(2));
        dw::SeriesQuery sq;
        sq.modality = "OT";
        auto none = c->searchSeries(m.studyUid, sq);
        QVERIFY(none.ok());
        QVERIFY(none->items.empty());
        expectError(c->searchSeries("1.2.x").error(), iris::Status::InvalidArgument, {"not a DICOM UID"});
        // The series URL opens through the DICOMweb source.
        const std::string url = c->seriesUrl(m.studyUid, x.seriesInstanceUid);
        QCOMPARE(url, server_->dicomWebRoot() + "/studies/" + m.studyUid + "/series/" + m.seriesUid);
        auto src = iris::openSlideSource(url, iris::SourcePreference::Auto, {});
        QVERIFY2(src.ok(), describe(src.ok() ? iris::Result() : src.error()).c_str());
        QVERIFY((*src)->info().levels.size() >= 1);
    }

    void refusedServiceUrls() {
        iris::NetworkOptions o;
        expectError(dw::QidoClient::create("ftp://127.0.0.1/dicom-web", o).error(), iris::Status::InvalidArgument,
                    {"http or https"});
        expectError(dw::QidoClient::create(std::string("http://iris:") + kPassword + "@127.0.0.1/dicom-web", o).error(),
                    iris::Status::InvalidArgument, {"credentials in the URL"});
        expectError(dw::QidoClient::create("http://pacs.example/dicom-web", o).error(), iris::Status::InvalidArgument,
                    {"plain http://"});
        o.caFile = (outDir() / "no-such-ca.pem").string();
        expectError(dw::QidoClient::create("https://pacs.example/dicom-web", o).error(), iris::Status::NotFound,
                    {"CA file"});
    }

    void basicAuth() {
        const std::string root = secured_->dicomWebRoot();
        dw::StudyQuery q;
        {
            auto c = client(root);
            QVERIFY(c);
            auto r = c->searchStudies(q);
            expectError(r.ok() ? iris::Result() : r.error(), iris::Status::IoError,
                        {"Cannot search studies on 127.0.0.1:", "asks for credentials", "HTTP 401"});
        }
        iris::NetworkOptions o;
        o.username = kUser;
        o.password = "wrong";
        {
            auto c = client(root, o);
            QVERIFY(c);
            auto r = c->searchStudies(q);
            expectError(r.ok() ? iris::Result() : r.error(), iris::Status::IoError,
                        {"refused the credentials given", "HTTP 401 Unauthorized"});
            QVERIFY(!contains(r.error().message(), "wrong"));
        }
        o.password = kPassword;
        auto c = client(root, o);
        QVERIFY(c);
        auto r = c->searchStudies(q);
        QVERIFY2(r.ok(), describe(r.ok() ? iris::Result() : r.error()).c_str());
        QCOMPARE(uidsOf(r->items), std::set<std::string>{securedStudy_.studyUid});
        auto s = c->searchSeries(securedStudy_.studyUid);
        QVERIFY(s.ok());
        QCOMPARE(s->items.size(), size_t(1));
    }

    // A server that lies: each answer a clear CorruptData (or the HTTP status's) error.
    void lyingServer() {
        std::string why;
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        auto c = client("http://127.0.0.1:" + std::to_string(proxy->port()) + "/dicom-web");
        QVERIFY(c);
        // Passing through: the proxy itself is honest.
        QVERIFY(c->searchStudies({}).ok());
        struct Case {
            long status;
            const char* type;
            std::string body;
            iris::Status expected;
            std::vector<std::string> words;
        };
        const std::string json = "application/dicom+json";
        const Case cases[] = {
            {200,
             json.c_str(),
             "<html><body>Bad gateway</body></html>",
             iris::Status::CorruptData,
             {"The QIDO-RS answer of GET http://127.0.0.1:", "/dicom-web/studies?", "is not valid JSON"}},
            {200, json.c_str(), "{\"Studies\": []}", iris::Status::CorruptData, {"is not a JSON array"}},
            {200,
             json.c_str(),
             "[{\"00100020\": {\"vr\": \"LO\", \"Value\": [\"PID1\"]}}]",
             iris::Status::CorruptData,
             {"element 1 has no StudyInstanceUID (0020,000D)"}},
            {200,
             "application/json",
             "[{\"0020000D\": {\"vr\": \"UI\", \"Value\": [\"1.2.3\"]}, \"00201208\": {\"vr\": \"IS\", \"Value\": "
             "[-4]}}]",
             iris::Status::CorruptData,
             {"NumberOfStudyRelatedInstances (0020,1208) is -4, not a count"}},
            {200,
             "text/html; charset=utf-8",
             "<html></html>",
             iris::Status::CorruptData,
             {"Content-Type 'text/html; charset=utf-8'", "not application/dicom+json"}},
            {500, json.c_str(), "", iris::Status::IoError, {"the server failed (HTTP 500 Internal Server Error)"}},
            {404, "text/plain", "", iris::Status::NotFound, {"the QIDO-RS service is not on the server (HTTP 404"}},
        };
        for (const Case& k : cases) {
            FaultProxy::Rule rule;
            rule.fault = FaultProxy::Fault::Replace;
            rule.pathContains = "/studies";
            rule.status = k.status;
            rule.type = k.type;
            rule.body = k.body;
            proxy->setRule(rule);
            auto r = c->searchStudies({});
            const iris::Result err = r.ok() ? iris::Result() : r.error();
            expectError(err, k.expected, {});
            if (QTest::currentTestFailed()) return;
            for (const std::string& w : k.words)
                QVERIFY2(contains(err.message(), w),
                         ("the message does not say '" + w + "': " + err.message()).c_str());
        }
        // A series answer that lists a series of another study.
        FaultProxy::Rule rule;
        rule.fault = FaultProxy::Fault::Replace;
        rule.pathContains = "/series";
        rule.type = json;
        rule.body = "[{\"0020000D\": {\"vr\": \"UI\", \"Value\": [\"9.9.9\"]}, \"0020000E\": {\"vr\": \"UI\", "
                    "\"Value\": [\"9.9.9.1\"]}}]";
        proxy->setRule(rule);
        auto s = c->searchSeries(studies_[0].studyUid);
        expectError(s.ok() ? iris::Result() : s.error(), iris::Status::CorruptData,
                    {"series of study '9.9.9', not of the study asked for"});
    }

    // The Engine: credentials given after it was made (setNetworkOptions) reach later open() calls.
    void engineCredentials() {
        auto c = client(secured_->dicomWebRoot(), {kUser, kPassword});
        QVERIFY(c);
        const std::string url = c->seriesUrl(securedStudy_.studyUid, securedStudy_.seriesUid);
        iris::EngineConfig cfg;
        cfg.color.managed = false;
        TestEngine e = createTestEngine(cfg);
        QVERIFY2(e, describe(e.error).c_str());
        QVERIFY(e->bindOffscreen(256, 256).ok());
        iris::Result r = e->open(url);
        expectError(r, iris::Status::IoError, {"asks for credentials", "HTTP 401"});
        iris::NetworkOptions o;
        o.username = kUser;
        o.password = "wrong";
        e->setNetworkOptions(o);
        r = e->open(url);
        expectError(r, iris::Status::IoError, {"refused the credentials given"});
        o.password = kPassword;
        e->setNetworkOptions(o);
        e->clearError();
        r = e->open(url);
        QVERIFY2(r.ok(), describe(r).c_str());
        QVERIFY2(e->waitForFrame(std::chrono::seconds(30)).ok(), "no frame of the protected series");
        auto frame = e->readFrame();
        QVERIFY(frame.ok());
        // Options set later do not touch the open slide: it keeps drawing.
        e->setNetworkOptions({});
        e->setView(e->fitView());
        QVERIFY(e->waitForFrame(std::chrono::seconds(30)).ok());
        const std::string problems = e.finish();
        QVERIFY2(problems.empty(), problems.c_str());
    }
};

QTEST_GUILESS_MAIN(TestQido)
#include "tst_qido.moc"
