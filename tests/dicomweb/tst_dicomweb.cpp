// The DICOMweb source (issue 15, "DICOMweb") against a real Orthanc with its DICOMweb plugin,
// started by the suite on 127.0.0.1 (orthanc_server.h), holding DICOM slides OrthancWSIDicomizer
// makes at test time from the sample slide and CMU-1-Small-Region (tests/support/dicomizer.h):
//   * pixel-exact: the series over DICOMweb reads and renders exactly as the same files do
//     locally (slide/dicom_source), tile by tile and through the Engine (colour management off);
//     JPEG frames of 256 (split levels) and 240 px, JPEG 2000 frames of 120×80;
//   * credentials and transport: basic authentication (a wrong password is a clear 401 error),
//     TLS with a CA the suite makes with openssl (trusted: works; untrusted: refused), URLs that
//     are refused before any request;
//   * frames come in frame lists (…/frames/a,b,c, many a request: counted by a proxy), and a
//     server that lies about lists (parts missing or swapped, a broken answer) or refuses them
//     (400, 404) still gives every tile exactly, one frame a request;
//   * frames kept on disk (NetworkOptions::frameCacheDirectory): a series opened again asks
//     the server for no frame, a damaged file is fetched again, an unusable folder is reported;
//   * faults, through a proxy that misbehaves on purpose (fault_proxy.h): a truncated multipart
//     body, a wrong content type, a 404 frame (the placeholder is drawn), a slow server (one that
//     holds every answer back: views keep moving, superseded requests are dropped), the server stopped in the middle of
//     a walk (clear error, the engine stays usable and recovers when the server is back), a server answering 503 while
//     views keep asking (the source backs off instead of hammering it), and an instance in a transfer syntax the engine
//     does not decode.
// Every wait is an engine event (waitForFrame) or a condition polled under a generous deadline;
// nothing sleeps a guess, and no assertion depends on how fast the machine is (the suite runs on
// a loaded 2-core CI machine too): where a test is about timing, it checks an order of events
// (answers held back while the views move) or a count, never a wall-clock bound.
#include <QtTest>

#include <chrono>
#include <fstream>
#include <set>

#include <dcmtk/config/osconfig.h>

#include <dcmtk/dcmdata/dcdatset.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcrleerg.h>
#include <dcmtk/dcmdata/dcuid.h>

#include "dicomizer.h"
#include "fault_proxy.h"
#include "h2_server.h"
#include "orthanc_server.h"
#include "slide/dicomweb_source.h"
#include "slide/slide_source.h"
#include "test_support.h"

using namespace iristest;
using namespace dicomwebtest;
using iris::kTileBytes;
using iris::kTileSize;
using Clock = std::chrono::steady_clock;

namespace {

#define CHECKED(call)                                                                                                  \
    do {                                                                                                               \
        call;                                                                                                          \
        if (QTest::currentTestFailed()) return;                                                                        \
    } while (0)

constexpr uint32_t kW = 384, kH = 256; // the engine's target

fs::path outDir() {
    const fs::path d = testOutDir() / "dicomweb";
    fs::create_directories(d);
    return d;
}

// The first .dcm file of a folder (any instance names the series).
fs::path firstFile(const fs::path& folder) {
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(folder))
        if (e.is_regular_file()) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files.empty() ? fs::path() : files.front();
}

std::unique_ptr<iris::SlideSource> openSource(const std::string& path, const iris::NetworkOptions& o,
                                              std::string* why) {
    auto r = iris::openSlideSource(path, iris::SourcePreference::Auto, o);
    if (!r.ok()) {
        *why = "cannot open " + path + ": " + describe(r.error());
        return nullptr;
    }
    return std::move(*r);
}

// open() fails with `status`, and the message holds every one of `words`.
void expectOpenFails(const std::string& url, const iris::NetworkOptions& o, iris::Status status,
                     std::initializer_list<std::string> words) {
    auto r = iris::openSlideSource(url, iris::SourcePreference::Auto, o);
    QVERIFY2(!r.ok(), ("opened " + url).c_str());
    const std::string& m = r.error().message();
    qInfo("%s", describe(r.error()).c_str());
    QVERIFY2(r.error().status() == status,
             ("status " + std::string(iris::statusName(r.error().status())) + ", expected " + iris::statusName(status))
                 .c_str());
    for (const std::string& w : words)
        QVERIFY2(m.find(w) != std::string::npos, ("the message does not say '" + w + "': " + m).c_str());
    if (!o.password.empty()) QVERIFY2(m.find(o.password) == std::string::npos, "the message shows the password");
}

// Every tile of every level of `web` equals `local`'s, byte for byte. Each level's tiles are
// hinted first (SlideSource::prefetch, as the loaders do), so that their frames come in parallel.
void expectSameTiles(iris::SlideSource& web, iris::SlideSource& local, const char* what) {
    const auto& a = web.info();
    const auto& b = local.info();
    QCOMPARE(a.levels.size(), b.levels.size());
    std::vector<uint8_t> ta(kTileBytes), tb(kTileBytes);
    uint64_t tiles = 0;
    for (size_t l = 0; l < a.levels.size(); ++l) {
        QCOMPARE(a.levels[l].width, b.levels[l].width);
        QCOMPARE(a.levels[l].height, b.levels[l].height);
        QCOMPARE(a.levels[l].downsample, b.levels[l].downsample);
        std::vector<iris::TileAddress> all;
        for (int64_t ty = 0; ty < a.levels[l].tilesY; ++ty)
            for (int64_t tx = 0; tx < a.levels[l].tilesX; ++tx) all.push_back({int(l), tx, ty});
        web.prefetch(all, [] {});
        for (int64_t ty = 0; ty < a.levels[l].tilesY; ++ty) {
            for (int64_t tx = 0; tx < a.levels[l].tilesX; ++tx) {
                const iris::Result ra = web.readTile(int(l), tx, ty, ta.data());
                QVERIFY2(ra.ok(), describe(ra).c_str());
                QVERIFY(local.readTile(int(l), tx, ty, tb.data()).ok());
                QVERIFY2(ta == tb,
                         qPrintable(QString("%1: level %2 tile (%3, %4) differs").arg(what).arg(l).arg(tx).arg(ty)));
                ++tiles;
            }
        }
    }
    qInfo("%s: %llu tiles identical", what, (unsigned long long)tiles);
}

// openssl, quietly; false when it failed.
bool openssl(const std::string& args, const fs::path& dir) {
    const std::string cmd = "cd '" + dir.string() + "' && openssl " + args + " >> openssl.log 2>&1";
    return std::system(cmd.c_str()) == 0;
}

// A CA and a server certificate for 127.0.0.1 signed by it (server.pem: certificate and key, as
// Orthanc wants them), and a second CA that signed nothing here.
bool makeCertificates(const fs::path& dir) {
    fs::create_directories(dir);
    { std::ofstream(dir / "san.cnf") << "subjectAltName=IP:127.0.0.1,DNS:localhost\n"; }
    const std::string ec = "-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
    return openssl("req -x509 " + ec + " -keyout ca.key -out ca.pem -days 2 -subj '/CN=Iris test CA'", dir) &&
           openssl("req -x509 " + ec + " -keyout other.key -out other-ca.pem -days 2 -subj '/CN=Other CA'", dir) &&
           openssl("req " + ec + " -keyout server.key -out server.csr -subj '/CN=127.0.0.1'", dir) &&
           openssl("x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out server.crt -days 2 "
                   "-extfile san.cnf",
                   dir) &&
           std::system(("cd '" + dir.string() + "' && cat server.crt server.key > server.pem").c_str()) == 0;
}

// The placeholder the loaders draw for a tile that cannot be read (slide_helpers.cpp).
std::vector<uint8_t> placeholderTile() {
    std::vector<uint8_t> t(kTileBytes);
    iris::fillFailedTilePlaceholder(t.data());
    return t;
}

} // namespace

class TestDicomWeb : public QObject {
    Q_OBJECT

    std::unique_ptr<OrthancServer> server_;  // plain http, no authentication
    fs::path sampleJpeg_, cmu240_, cmuJp2k_; // the local series folders
    std::string sampleUrl_, cmu240Url_, cmuJp2kUrl_;
    TestEngine e_;

    // `url` (on the suite's Orthanc) reached through `proxy` instead.
    std::string through(const FaultProxy& proxy, std::string url) const {
        const std::string port = ":" + std::to_string(server_->port()) + "/";
        url.replace(url.find(port), port.size(), ":" + std::to_string(proxy.port()) + "/");
        return url;
    }

    // Renders `view` of `path` (a folder or a URL) through the suite's engine.
    std::optional<iris::Frame> render(const std::string& path, const iris::View& view, std::string* why) {
        const iris::Result r = e_->open(path);
        if (!r.ok()) {
            *why = "open " + path + ": " + describe(r);
            return std::nullopt;
        }
        return renderView(*e_.engine, view, kW, kH, std::chrono::seconds(60), why);
    }
    // The frames of `view` from the local folder and from the URL are identical.
    void expectSameFrame(const fs::path& local, const std::string& url, const iris::View& view, const char* what) {
        std::string why;
        auto a = render(local.string(), view, &why);
        QVERIFY2(a, why.c_str());
        auto b = render(url, view, &why);
        QVERIFY2(b, why.c_str());
        const DiffStats st = compareImages(b->image, a->image);
        qInfo("%s at (%.0f, %.0f) downsample %g: %s", what, view.centerX, view.centerY, view.downsample,
              st.summary().c_str());
        QVERIFY2(st.differing == 0,
                 saveFailureArtefacts(std::string("dicomweb.") + what, b->image, a->image, nullptr).c_str());
    }

private slots:
    void initTestCase() {
        if (!dicomizerInstalled())
            QFAIL("OrthancWSIDicomizer (Debian orthanc-wsi) is not installed: scripts/install-deps.sh");
        if (std::system("command -v Orthanc > /dev/null 2>&1") != 0)
            QFAIL("Orthanc (Debian orthanc, orthanc-dicomweb) is not installed: scripts/install-deps.sh installs it");
        auto sample = sampleSlidePath();
        auto aperio = slidesDir("aperio");
        QVERIFY2(sample && fs::exists(*sample), "no sample slide (IRIS_TEST_SAMPLE)");
        if (!aperio) QSKIP("no test data");
        std::string why;
        const fs::path out = outDir();
        // The sample with its JPEG tiles copied (256 px frames, YBR_FULL_422), level 0 in 4 files;
        // CMU-1-Small-Region's 240 px RGB JPEG frames; JPEG 2000 frames of 120×80.
        auto a = dicomize(out / "sample-jpeg", *sample, "--reencode=0 --max-size=1", &why);
        QVERIFY2(a, why.c_str());
        auto b = dicomize(out / "cmu-240", *aperio / "CMU-1-Small-Region.svs", "--reencode=0", &why);
        QVERIFY2(b, why.c_str());
        auto c = dicomize(out / "cmu-jp2k-120x80", *aperio / "CMU-1-Small-Region.svs",
                          "--compression=jpeg2000 --tile-width=120 --tile-height=80", &why);
        QVERIFY2(c, why.c_str());
        sampleJpeg_ = *a;
        cmu240_ = *b;
        cmuJp2k_ = *c;
        server_ = OrthancServer::start(out / "orthanc", {}, &why);
        QVERIFY2(server_, why.c_str());
        for (const fs::path& f : {sampleJpeg_, cmu240_, cmuJp2k_}) QVERIFY2(server_->upload(f, &why), why.c_str());
        sampleUrl_ = server_->seriesUrl(firstFile(sampleJpeg_));
        cmu240Url_ = server_->seriesUrl(firstFile(cmu240_));
        cmuJp2kUrl_ = server_->seriesUrl(firstFile(cmuJp2k_));
        qInfo("Orthanc on port %d; sample series %s", server_->port(), sampleUrl_.c_str());

        iris::EngineConfig cfg;
        cfg.color.managed = false; // the slide's stored bytes, as the local pixel-exact suites compare
        e_ = createTestEngine(cfg);
        QVERIFY2(e_, describe(e_.error).c_str());
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
    }

    void cleanupTestCase() {
        const std::string why = e_.finish();
        server_.reset();
        QVERIFY2(why.empty(), why.c_str());
    }

    // Tile by tile, every level: the DICOMweb source reads what the local files hold, and its
    // structure and metadata are the local source's. (The other cases read tiles nobody hinted:
    // the source's direct path, which requests the frame first in line and waits.)
    void sourceMatchesLocal_data() {
        QTest::addColumn<int>("which");
        QTest::newRow("sample-jpeg-256") << 0;
        QTest::newRow("cmu-jpeg-240") << 1;
        QTest::newRow("cmu-jp2k-120x80") << 2;
    }
    void sourceMatchesLocal() {
        QFETCH(int, which);
        const fs::path& folder = which == 0 ? sampleJpeg_ : which == 1 ? cmu240_ : cmuJp2k_;
        const std::string& url = which == 0 ? sampleUrl_ : which == 1 ? cmu240Url_ : cmuJp2kUrl_;
        std::string why;
        auto local = openSource(folder.string(), {}, &why);
        auto web = openSource(url, {}, &why);
        QVERIFY2(local && web, why.c_str());
        const iris::SlideInfo& a = web->info();
        const iris::SlideInfo& b = local->info();
        QCOMPARE(a.path, url);
        QCOMPARE(a.width, b.width);
        QCOMPARE(a.vendor, b.vendor);
        QCOMPARE(a.mppX, b.mppX);
        QCOMPARE(a.mppY, b.mppY);
        QCOMPARE(a.objectivePower, b.objectivePower);
        QCOMPARE(a.associatedImages, b.associatedImages);
        QVERIFY2(!a.iccProfile.empty(), "the ICC profile (bulk data) was not fetched");
        QVERIFY2(a.iccProfile == b.iccProfile, "the ICC profile differs");
        // Properties: the same keys; the values the same apart from numbers the server rewrote.
        int same = 0, differ = 0;
        for (const auto& [key, value] : b.properties) {
            const auto it =
                std::find_if(a.properties.begin(), a.properties.end(), [&](const auto& p) { return p.first == key; });
            QVERIFY2(it != a.properties.end(), ("missing property " + key).c_str());
            if (it->second == value)
                ++same;
            else
                ++differ, qInfo("property %s: '%s' over DICOMweb, '%s' locally", key.c_str(), it->second.c_str(),
                                value.c_str());
        }
        qInfo("%d properties equal, %d differ in their rendering", same, differ);
        for (const char* key : {"dicom.TransferSyntaxUID", "dicom.SOPInstanceUID", "dicom.TotalPixelMatrixColumns",
                                "dicom.PhotometricInterpretation", "dicom.Manufacturer", "dicom.SeriesInstanceUID"}) {
            const auto value = [&](const iris::SlideInfo& info) {
                for (const auto& [k, v] : info.properties)
                    if (k == key) return v;
                return std::string("(absent)");
            };
            QCOMPARE(value(a), value(b));
        }
        // The tiles through a proxy that passes everything on and counts the requests. (Not
        // the metadata: the ICC profile's BulkDataURI names the server itself, which a source
        // opened through the proxy does not fetch, another origin.)
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        web = openSource(through(*proxy, url), {}, &why);
        QVERIFY2(web, why.c_str());
        proxy->resetCount(); // open's own requests: frame 1 of each instance, one a request
        CHECKED(expectSameTiles(*web, *local, QTest::currentDataTag()));
        // The hinted frames came in frame lists (…/frames/a,b,c), many a request.
        const int requests = proxy->frameRequests(), lists = proxy->listRequests(), frames = proxy->framesAsked();
        qInfo("%d frames in %d requests (%d of them frame lists)", frames, requests, lists);
        QVERIFY2(lists > 0, "no frame list was asked for");
        QVERIFY2(frames >= 4 * requests, "fewer than 4 frames a request on average: the frames were not batched");
    }

    // Through the Engine (prefetch batches, the loaders' held claims): frames identical to the
    // local series', at 1:1 and at a level's downsample, for each frame size.
    // The frames come in frame lists (counted by a proxy that passes everything on).
    void engineMatchesLocal() {
        std::string why;
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        e_.beginTest();
        const std::string sample = through(*proxy, sampleUrl_);
        CHECKED(expectSameFrame(sampleJpeg_, sample, viewWithOrigin(1234, 987, 1, kW, kH), "sample"));
        CHECKED(expectSameFrame(sampleJpeg_, sample, viewWithOrigin(4000, 2500, 1, kW, kH), "sample"));
        CHECKED(expectSameFrame(sampleJpeg_, sample, viewWithOrigin(512, 256, 4, kW, kH), "sample"));
        CHECKED(expectSameFrame(cmu240_, through(*proxy, cmu240Url_), viewWithOrigin(700, 900, 1, kW, kH), "cmu-240"));
        CHECKED(
            expectSameFrame(cmuJp2k_, through(*proxy, cmuJp2kUrl_), viewWithOrigin(700, 900, 1, kW, kH), "cmu-jp2k"));
        const std::string lines = e_.endTest();
        QVERIFY2(lines.empty(), lines.c_str());
        qInfo("%d frames in %d requests (%d of them frame lists, the rest single frames: open's and small levels')",
              proxy->framesAsked(), proxy->frameRequests(), proxy->listRequests());
        QVERIFY2(proxy->listRequests() > 0, "no frame list was asked for");
        e_->close();
    }

    // Basic authentication on a second Orthanc, reached over TLS through the suite's proxy
    // (Debian 12's Orthanc cannot serve HTTPS itself: fault_proxy.h); URLs refused before any
    // request.
    void credentialsAndTls() {
        const fs::path dir = outDir() / "tls";
        QVERIFY2(makeCertificates(dir / "certs"),
                 ("openssl failed: see " + (dir / "certs" / "openssl.log").string()).c_str());
        OrthancOptions o;
        o.user = "pathologist";
        o.password = "correct-horse";
        std::string why;
        auto server = OrthancServer::start(dir / "orthanc", o, &why);
        QVERIFY2(server, why.c_str());
        QVERIFY2(server->upload(cmu240_, &why), why.c_str());
        const FaultProxy::Tls tls{(dir / "certs" / "server.crt").string(), (dir / "certs" / "server.key").string()};
        auto proxy = FaultProxy::start(server->port(), &why, &tls);
        QVERIFY2(proxy, why.c_str());
        const std::string plainUrl = server->seriesUrl(firstFile(cmu240_));
        const std::string origin = "http://127.0.0.1:" + std::to_string(server->port());
        const std::string url = "https://127.0.0.1:" + std::to_string(proxy->port()) + plainUrl.substr(origin.size());

        iris::NetworkOptions good;
        good.username = o.user;
        good.password = o.password;
        good.caFile = (dir / "certs" / "ca.pem").string();
        for (const std::string& u : {url, plainUrl}) { // over TLS, and plain http on loopback
            auto web = openSource(u, good, &why);
            QVERIFY2(web, why.c_str());
            auto local = openSource(cmu240_.string(), {}, &why);
            std::vector<uint8_t> a(kTileBytes), b(kTileBytes);
            QVERIFY(web->readTile(0, 3, 4, a.data()).ok());
            QVERIFY(local->readTile(0, 3, 4, b.data()).ok());
            QVERIFY(a == b);
        }
        // Through the Engine: EngineConfig::network reaches the source, and a frame is drawn
        // over TLS with basic authentication; an engine without the credentials is refused.
        {
            iris::EngineConfig cfg;
            cfg.color.managed = false;
            cfg.network = good;
            TestEngine withCredentials = createTestEngine(cfg);
            QVERIFY2(withCredentials, describe(withCredentials.error).c_str());
            QVERIFY(withCredentials->bindOffscreen(kW, kH).ok());
            const iris::Result opened = withCredentials->open(url);
            QVERIFY2(opened.ok(), describe(opened).c_str());
            withCredentials->setView(viewWithOrigin(700, 900, 1, kW, kH));
            QVERIFY(withCredentials->waitForFrame(std::chrono::seconds(30)).ok());
            const std::string problems = withCredentials.finish();
            QVERIFY2(problems.empty(), problems.c_str());
            cfg.network = {};
            cfg.network.caFile = good.caFile;
            TestEngine without = createTestEngine(cfg);
            QVERIFY2(without, describe(without.error).c_str());
            const iris::Result refused = without->open(url);
            QCOMPARE(refused.status(), iris::Status::IoError);
            QVERIFY2(refused.message().find("HTTP 401") != std::string::npos, refused.message().c_str());
            without->clearError();
            const std::string problems2 = without.finish();
            QVERIFY2(problems2.empty(), problems2.c_str());
        }
        iris::NetworkOptions wrong = good;
        wrong.password = "tr0ub4dor";
        CHECKED(expectOpenFails(url, wrong, iris::Status::IoError, {"HTTP 401", "refused the credentials"}));
        CHECKED(expectOpenFails(plainUrl, wrong, iris::Status::IoError, {"HTTP 401", "refused the credentials"}));
        iris::NetworkOptions none = good;
        none.username.clear();
        none.password.clear();
        CHECKED(expectOpenFails(url, none, iris::Status::IoError, {"HTTP 401", "asks for credentials"}));
        iris::NetworkOptions bearer = none;
        bearer.bearerToken = "not-a-token-this-server-knows";
        CHECKED(expectOpenFails(url, bearer, iris::Status::IoError, {"HTTP 401", "refused the credentials"}));
        // Untrusted certificates: the system's CAs (which never signed it), and another CA.
        iris::NetworkOptions systemCas = good;
        systemCas.caFile.clear();
        CHECKED(expectOpenFails(url, systemCas, iris::Status::IoError, {"TLS failed", "not trusted"}));
        iris::NetworkOptions otherCa = good;
        otherCa.caFile = (dir / "certs" / "other-ca.pem").string();
        CHECKED(expectOpenFails(url, otherCa, iris::Status::IoError, {"TLS failed", "not trusted"}));
        iris::NetworkOptions missingCa = good;
        missingCa.caFile = (dir / "certs" / "no-such-ca.pem").string();
        CHECKED(expectOpenFails(url, missingCa, iris::Status::NotFound, {"no-such-ca.pem"}));
        // Plain http to the TLS port is not DICOMweb: a clear error, not a hang.
        {
            std::string plain = url;
            plain.replace(0, 5, "http");
            auto r = iris::openSlideSource(plain, iris::SourcePreference::Auto, good);
            QVERIFY(!r.ok());
            qInfo("plain http to the TLS port: %s", describe(r.error()).c_str());
        }

        // Refused before any request: plain http to a host that is not loopback, credentials
        // in the URL, a URL that is not a series; and a series the server does not have.
        CHECKED(expectOpenFails("http://192.0.2.7/dicom-web/studies/1.2.3/series/1.2.4", {},
                                iris::Status::InvalidArgument, {"plain http://", "allowPlainHttp"}));
        CHECKED(expectOpenFails("https://user:secret@127.0.0.1:9/dicom-web/studies/1.2/series/1.3", {},
                                iris::Status::InvalidArgument, {"credentials in the URL"}));
        {
            auto r = iris::openSlideSource("https://user:secret@127.0.0.1:9/dicom-web/studies/1.2/series/1.3");
            QVERIFY(!r.ok() && r.error().message().find("secret") == std::string::npos);
        }
        CHECKED(expectOpenFails(server_->dicomWebRoot() + "/studies/1.2.3", {}, iris::Status::InvalidArgument,
                                {"/studies/<Study Instance UID>/series/<Series Instance UID>"}));
        CHECKED(expectOpenFails(server_->dicomWebRoot() + "/studies/1.2.3/series/4.5.6", {}, iris::Status::NotFound,
                                {"is not on the server", "HTTP 404"}));
        proxy.reset();
        QVERIFY(server->stop());
    }

    // HTTP/2 where the server speaks it: through nghttpx (HTTP/2 over TLS, negotiated by ALPN,
    // in front of Orthanc) every frame request goes over HTTP/2 (the server's access log names
    // the protocol of each), multiplexed on one or two connections where HTTP/1.1 opens up to
    // six, and every tile equals the local series'.
    void http2WhereTheServerSpeaksIt() {
        const fs::path dir = outDir() / "h2";
        QVERIFY2(makeCertificates(dir / "certs"),
                 ("openssl failed: see " + (dir / "certs" / "openssl.log").string()).c_str());
        std::string why;
        auto h2 = H2Server::start(dir / "nghttpx", server_->port(), dir / "certs" / "server.crt",
                                  dir / "certs" / "server.key", &why);
        QVERIFY2(h2, why.c_str());
        const std::string origin = "http://127.0.0.1:" + std::to_string(server_->port());
        QVERIFY(sampleUrl_.rfind(origin, 0) == 0);
        const std::string url = "https://127.0.0.1:" + std::to_string(h2->port()) + sampleUrl_.substr(origin.size());
        iris::NetworkOptions o;
        o.caFile = (dir / "certs" / "ca.pem").string();
        auto web = openSource(url, o, &why);
        QVERIFY2(web, why.c_str());
        auto local = openSource(sampleJpeg_.string(), {}, &why);
        QVERIFY2(local, why.c_str());
        CHECKED(expectSameTiles(*web, *local, "over HTTP/2"));
        web.reset();
        int frames = 0, overH2 = 0;
        std::set<std::string> ports;
        for (const std::string& line : h2->accessLog()) {
            if (line.find("/frames/") == std::string::npos) continue;
            ++frames;
            if (line.rfind("h2 ", 0) == 0) ++overH2;
            const size_t a = line.find(' ') + 1;
            ports.insert(line.substr(a, line.find(' ', a) - a));
        }
        qInfo("%d frame requests, %d of them over HTTP/2, on %zu connections", frames, overH2, ports.size());
        QVERIFY2(frames > 0, "nghttpx logged no frame request");
        QCOMPARE(overH2, frames);
        QVERIFY2(ports.size() <= 2, "the requests were not multiplexed");
        QVERIFY(h2->stop());
    }

    // Broken answers for frames 2 and later (frame 1 of each instance is read at open): each a
    // clear error for the tile that needs the frame; the tiles around it still read.
    // The frames that arrived are kept, compressed, within the store's budget: read a second
    // time from a store that holds them they cost no request; from one that holds none (a
    // budget of one byte) each is asked for again, and still arrives exactly. The engine gives
    // the store 1/16 of its RAM budget, from 4 MiB to 1 GiB.
    void frameStoreFollowsItsBudget() {
        using iris::DicomWebSource;
        QCOMPARE(DicomWebSource::frameStoreBytesFor(uint64_t(1) << 30), uint64_t(64) << 20);
        QCOMPARE(DicomWebSource::frameStoreBytesFor(uint64_t(16) << 20), uint64_t(4) << 20);
        QCOMPARE(DicomWebSource::frameStoreBytesFor(uint64_t(64) << 30), uint64_t(1) << 30);
        std::string why;
        auto local = openSource(sampleJpeg_.string(), {}, &why);
        QVERIFY2(local, why.c_str());
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        const int level = 1; // 12 × 8 tiles
        std::vector<uint8_t> ta(kTileBytes), tb(kTileBytes);
        // Reads every tile of the level twice (hinted once, as the loaders do) and returns the
        // frames asked for by the second pass.
        const auto twice = [&](iris::SlideSource& web, int* second) {
            const iris::LevelInfo& l = web.info().levels[level];
            std::vector<iris::TileAddress> all;
            for (int64_t ty = 0; ty < l.tilesY; ++ty)
                for (int64_t tx = 0; tx < l.tilesX; ++tx) all.push_back({level, tx, ty});
            web.prefetch(all, [] {});
            for (int pass = 0; pass < 2; ++pass) {
                if (pass == 1) proxy->resetCount();
                for (const iris::TileAddress& a : all) {
                    const iris::Result r = web.readTile(a.level, a.tx, a.ty, ta.data());
                    QVERIFY2(r.ok(), describe(r).c_str());
                    QVERIFY(local->readTile(a.level, a.tx, a.ty, tb.data()).ok());
                    QVERIFY2(ta == tb, qPrintable(QString("tile (%1, %2) differs").arg(a.tx).arg(a.ty)));
                }
            }
            *second = proxy->framesAsked();
        };
        int keptAsked = -1, noneAsked = -1;
        {
            auto web = openSource(through(*proxy, sampleUrl_), {}, &why);
            QVERIFY2(web, why.c_str());
            CHECKED(twice(*web, &keptAsked));
        }
        {
            auto web = openSource(through(*proxy, sampleUrl_), {}, &why);
            QVERIFY2(web, why.c_str());
            auto* dw = dynamic_cast<DicomWebSource*>(web.get());
            QVERIFY(dw);
            dw->setFrameStoreBytes(1);
            CHECKED(twice(*web, &noneAsked));
        }
        const int tiles = int(local->info().levels[level].tilesX * local->info().levels[level].tilesY);
        qInfo("second pass over %d tiles: %d frames asked for with the default store, %d with a store of one byte",
              tiles, keptAsked, noneAsked);
        QCOMPARE(keptAsked, 0);
        QVERIFY2(noneAsked >= tiles - 1, "frames read before were kept beyond the store's budget");
    }

    // NetworkOptions::frameCacheDirectory: frames fetched once are kept on disk (net::
    // FrameDiskCache), so that the series opened again asks the server for its metadata only
    // (open's first frames and every tile come from the folder), tiles still equal the local
    // series' byte for byte; a damaged file is a miss (fetched again, never drawn); a folder that
    // cannot be used costs the cache, not the slide. Counted by a proxy that passes everything on.
    void framesKeptOnDisk() {
        std::string why;
        auto local = openSource(sampleJpeg_.string(), {}, &why);
        QVERIFY2(local, why.c_str());
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        const fs::path dir = outDir() / "frame-cache";
        fs::remove_all(dir);
        iris::NetworkOptions o;
        o.frameCacheDirectory = dir.string();
        const std::string url = through(*proxy, sampleUrl_);
        const int level = 1; // 12 × 8 tiles
        std::vector<uint8_t> ta(kTileBytes), tb(kTileBytes);
        // Every tile of the level, hinted at once as the loaders do, equals the local one.
        const auto readLevel = [&](iris::SlideSource& web) {
            const iris::LevelInfo& l = web.info().levels[level];
            std::vector<iris::TileAddress> all;
            for (int64_t ty = 0; ty < l.tilesY; ++ty)
                for (int64_t tx = 0; tx < l.tilesX; ++tx) all.push_back({level, tx, ty});
            web.prefetch(all, [] {});
            for (const iris::TileAddress& a : all) {
                const iris::Result r = web.readTile(a.level, a.tx, a.ty, ta.data());
                QVERIFY2(r.ok(), describe(r).c_str());
                QVERIFY(local->readTile(a.level, a.tx, a.ty, tb.data()).ok());
                QVERIFY2(ta == tb, qPrintable(QString("tile (%1, %2) differs").arg(a.tx).arg(a.ty)));
            }
        };
        const auto keptFiles = [&] {
            std::vector<fs::path> files;
            for (const auto& e : fs::recursive_directory_iterator(dir))
                if (e.is_regular_file() && e.path().filename().string().size() == 16) files.push_back(e.path());
            std::sort(files.begin(), files.end());
            return files;
        };
        proxy->resetCount();
        {
            auto web = openSource(url, o, &why);
            QVERIFY2(web, why.c_str());
            CHECKED(readLevel(*web));
        } // the source lets the cache go: what it queued is written before this returns
        const int fetched = proxy->framesAsked();
        QVERIFY2(fetched > 0, "nothing was fetched the first time");
        QVERIFY2(fs::status(dir).permissions() == fs::perms::owner_all, "the folder is not the user's alone");
        const std::vector<fs::path> files = keptFiles();
        qInfo("first open: %d frames fetched, %zu files kept", fetched, files.size());
        QVERIFY2(int(files.size()) >= fetched, "not every fetched frame was kept");

        // Opened again: the metadata from the server, every frame from the disk.
        proxy->resetCount();
        {
            auto web = openSource(url, o, &why);
            QVERIFY2(web, why.c_str());
            QCOMPARE(proxy->frameRequests(), 0); // open's first frames too
            CHECKED(readLevel(*web));
            QCOMPARE(proxy->frameRequests(), 0);
            for (const auto& [key, value] : web->info().properties)
                QVERIFY2(key != "dicomweb.FrameCacheError", value.c_str());
        }

        // Three files damaged (a byte flipped, one cut short, one emptied): those frames are
        // fetched again, and every tile still equals the local one.
        QVERIFY(files.size() > 8);
        {
            std::fstream f(files[2], std::ios::in | std::ios::out | std::ios::binary);
            f.seekg(-10, std::ios::end);
            char c = 0;
            f.get(c);
            f.seekp(-10, std::ios::end);
            f.put(char(c ^ 0x20));
        }
        fs::resize_file(files[5], fs::file_size(files[5]) - 1);
        fs::resize_file(files[8], 0);
        proxy->resetCount();
        {
            auto web = openSource(url, o, &why);
            QVERIFY2(web, why.c_str());
            CHECKED(readLevel(*web));
        }
        qInfo("3 files damaged: %d frames fetched again", proxy->framesAsked());
        QVERIFY2(proxy->framesAsked() >= 1 && proxy->framesAsked() <= 3,
                 "the damaged frames were not fetched again, or intact ones were");
        QCOMPARE(keptFiles().size(), files.size()); // and kept again

        // A folder that cannot be used: the slide opens and reads without it, and says why.
        const fs::path notAFolder = outDir() / "frame-cache-is-a-file";
        { std::ofstream(notAFolder) << "x"; }
        o.frameCacheDirectory = notAFolder.string();
        auto web = openSource(url, o, &why);
        QVERIFY2(web, why.c_str());
        std::string error;
        for (const auto& [key, value] : web->info().properties)
            if (key == "dicomweb.FrameCacheError") error = value;
        qInfo("unusable folder: %s", error.c_str());
        QVERIFY2(error.find("not a folder") != std::string::npos, error.c_str());
        CHECKED(readLevel(*web));
    }

    // Through the Engine with the cache on: the frames drawn from kept frames equal the local
    // series' (at 1:1 and at level 1's downsample), opened twice.
    void engineWithFramesKeptOnDisk() {
        const fs::path dir = outDir() / "frame-cache-engine";
        fs::remove_all(dir);
        iris::NetworkOptions o;
        o.frameCacheDirectory = dir.string();
        e_->setNetworkOptions(o);
        e_.beginTest();
        for (int pass = 0; pass < 2; ++pass) {
            CHECKED(expectSameFrame(sampleJpeg_, sampleUrl_, viewWithOrigin(2222, 1111, 1, kW, kH), "kept frames"));
            CHECKED(expectSameFrame(sampleJpeg_, sampleUrl_, viewWithOrigin(768, 512, 4, kW, kH), "kept frames"));
            e_->close();
        }
        e_->setNetworkOptions({});
        const std::string lines = e_.endTest();
        QVERIFY2(lines.empty(), lines.c_str());
        QVERIFY2(fs::exists(dir), "the engine kept no frame");
    }

    // Each fault twice: for a frame read alone (a read nobody hinted), and for frames hinted
    // with their row, which go in a frame list first: the list's answer is broken too, so its
    // frames are asked for alone, and each gets its own answer and error.
    void brokenAnswers_data() {
        QTest::addColumn<int>("fault");
        QTest::addColumn<int>("status");
        QTest::addColumn<QString>("words");
        QTest::addColumn<bool>("hinted");
        for (const bool hinted : {false, true}) {
            const std::string how = hinted ? " (hinted: a frame list first)" : "";
            QTest::newRow(("truncated multipart" + how).c_str())
                << int(FaultProxy::Fault::Truncate) << int(iris::Status::CorruptData) << "cut short" << hinted;
            QTest::newRow(("wrong content type" + how).c_str())
                << int(FaultProxy::Fault::WrongType) << int(iris::Status::CorruptData)
                << "Content-Type 'text/html; charset=utf-8', not multipart/related" << hinted;
            QTest::newRow(("404 frame" + how).c_str())
                << int(FaultProxy::Fault::NotFound) << int(iris::Status::NotFound)
                << "is not on the server (HTTP 404 Not Found)" << hinted;
        }
    }
    void brokenAnswers() {
        QFETCH(int, fault);
        QFETCH(int, status);
        QFETCH(QString, words);
        QFETCH(bool, hinted);
        std::string why;
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        proxy->setRule({.fault = FaultProxy::Fault(fault), .fromFrame = 2});
        const std::string url = through(*proxy, sampleUrl_);
        auto web = openSource(url, {}, &why);
        QVERIFY2(web, why.c_str());
        auto local = openSource(sampleJpeg_.string(), {}, &why);
        std::vector<uint8_t> a(kTileBytes), b(kTileBytes);
        if (hinted) {
            std::vector<iris::TileAddress> row;
            for (int64_t tx = 0; tx < web->info().levels[0].tilesX; ++tx) row.push_back({0, tx, 0});
            web->prefetch(row, [] {});
        }
        // Level 0's tile (0, 0) is frame 1 of its first instance; (1, 0) is frame 2.
        QVERIFY(web->readTile(0, 0, 0, a.data()).ok());
        QVERIFY(local->readTile(0, 0, 0, b.data()).ok());
        QVERIFY(a == b);
        const iris::Result r = web->readTile(0, 1, 0, a.data());
        qInfo("%s", describe(r).c_str());
        QVERIFY(!r.ok());
        QCOMPARE(int(r.status()), status);
        QVERIFY2(r.message().find(words.toStdString()) != std::string::npos, r.message().c_str());
        QVERIFY2(r.message().find("frame 2 of DICOMweb instance") != std::string::npos, r.message().c_str());
        if (hinted) QVERIFY2(proxy->listRequests() > 0, "the hinted row was not asked for in a frame list");
    }

    // A server that lies about frame lists, or refuses them (400 or 404 for any list, as some
    // do), while it answers single frames right: the source never keeps a frame from a list
    // answered wrong (parts missing or swapped: each part names its frame, Content-Location),
    // asks for those frames alone, and after two such lists asks for single frames only. Every
    // tile of the level still reads exactly as the local series'.
    void brokenFrameLists_data() {
        QTest::addColumn<int>("fault");
        QTest::newRow("list answer cut short") << int(FaultProxy::Fault::Truncate);
        QTest::newRow("list answer of a wrong type") << int(FaultProxy::Fault::WrongType);
        QTest::newRow("list answer missing a part") << int(FaultProxy::Fault::DropPart);
        QTest::newRow("list answer with parts swapped") << int(FaultProxy::Fault::SwapParts);
        QTest::newRow("lists refused (400)") << int(FaultProxy::Fault::RefuseLists);
        QTest::newRow("lists not found (404)") << int(FaultProxy::Fault::NotFound);
    }
    void brokenFrameLists() {
        QFETCH(int, fault);
        std::string why;
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        proxy->setRule({.fault = FaultProxy::Fault(fault), .listsOnly = true});
        auto web = openSource(through(*proxy, sampleUrl_), {}, &why);
        QVERIFY2(web, why.c_str());
        auto local = openSource(sampleJpeg_.string(), {}, &why);
        QVERIFY2(local, why.c_str());
        proxy->resetCount();
        std::vector<uint8_t> a(kTileBytes), b(kTileBytes);
        // Two rows of level 0, each hinted at once (a batch: its frames of one instance go in
        // one list), then two of level 1 (lists no more: two were answered wrong).
        for (int level = 0; level < 2; ++level) {
            const iris::LevelInfo& L = web->info().levels[size_t(level)];
            for (int64_t ty = 0; ty < std::min<int64_t>(L.tilesY, 2); ++ty) {
                std::vector<iris::TileAddress> row;
                for (int64_t tx = 0; tx < L.tilesX; ++tx) row.push_back({level, tx, ty});
                web->prefetch(row, [] {});
                for (const iris::TileAddress& t : row) {
                    const iris::Result r = web->readTile(level, t.tx, t.ty, a.data());
                    QVERIFY2(r.ok(), describe(r).c_str());
                    QVERIFY(local->readTile(level, t.tx, t.ty, b.data()).ok());
                    QVERIFY2(a == b,
                             qPrintable(QString("level %1 tile (%2, %3) differs").arg(level).arg(t.tx).arg(t.ty)));
                }
            }
            const int requests = proxy->frameRequests(), lists = proxy->listRequests();
            qInfo("level %d: %d frames in %d requests, %d of them lists", level, proxy->framesAsked(), requests, lists);
            if (level == 0) {
                QVERIFY2(lists >= 2, "fewer than two frame lists were asked for");
                QVERIFY2(requests > lists, "the frames of the lists answered wrong were not asked for alone");
            } else {
                QCOMPARE(lists, 0); // a server that has refused lists is asked for single frames only
            }
            proxy->resetCount();
        }
    }

    // Through the Engine: a frame the server does not have is drawn as the placeholder, the
    // frame completes, and the engine reports the error; the other tiles are the slide's.
    void missingFrameDrawsPlaceholder() {
        std::string why;
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        // Level 0's frames 2..: at the view below every tile but (0, 0) is missing.
        proxy->setRule({.fault = FaultProxy::Fault::NotFound, .fromFrame = 2});
        const std::string url = through(*proxy, sampleUrl_);
        e_.beginTest();
        const iris::View view = viewWithOrigin(0, 0, 1, kW, kH);
        auto local = render(sampleJpeg_.string(), view, &why);
        QVERIFY2(local, why.c_str());
        auto web = render(url, view, &why);
        QVERIFY2(web, why.c_str());
        const iris::Result err = e_->error();
        qInfo("engine error: %s", describe(err).c_str());
        QCOMPARE(err.status(), iris::Status::NotFound);
        // Tile (0, 0) is the slide's; tile (1, 0) (frame pixels 256…383 of row 0) the placeholder.
        const std::vector<uint8_t> ph = placeholderTile();
        for (uint32_t y = 0; y < kTileSize; ++y) {
            for (uint32_t x = 0; x < kTileSize; ++x) {
                QVERIFY(std::memcmp(pixel(web->image, x, y), pixel(local->image, x, y), 4) == 0);
                if (x + kTileSize < kW) {
                    const uint8_t* p = pixel(web->image, x + kTileSize, y);
                    QVERIFY2(std::memcmp(p, ph.data() + (size_t(y) * kTileSize + x) * 4, 3) == 0,
                             qPrintable(QString("pixel (%1, %2) is not the placeholder's").arg(x + kTileSize).arg(y)));
                }
            }
        }
        const std::string lines = e_.endTest(TestEngine::ErrorLines::Show);
        QVERIFY2(lines.empty(), lines.c_str());
        e_->close();
    }

    // Through the Engine: frames that fail for a reason that may pass (503) are drawn as the
    // placeholder while they fail, not as the coarser level beneath (which a pathologist could
    // take for the slide's own pixels), and the frame stays incomplete; once the server answers,
    // the same view, unchanged, loads exactly.
    void failingFrameDrawsPlaceholderUntilBack() {
        std::string why;
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        const std::string url = through(*proxy, sampleUrl_);
        e_.beginTest();
        const iris::View view = viewWithOrigin(0, 0, 1, kW, kH);
        auto local = render(sampleJpeg_.string(), view, &why);
        QVERIFY2(local, why.c_str());
        // Frame 1 of each instance passes (open reads it); every request for a later frame fails.
        proxy->setRule({.fault = FaultProxy::Fault::Unavailable, .fromFrame = 2});
        QVERIFY(e_->open(url).ok());
        e_->setView(view);
        // Tile (1, 0) of level 0 (frame 2) fails after its attempts (about 1.3 s): then a frame
        // shows the placeholder there. Bounded.
        const std::vector<uint8_t> ph = placeholderTile();
        const auto showsPlaceholder = [&](const iris::Image& im) {
            for (uint32_t y = 0; y < kTileSize; ++y)
                for (uint32_t x = 0; x + kTileSize < kW; ++x)
                    if (std::memcmp(pixel(im, x + kTileSize, y), ph.data() + (size_t(y) * kTileSize + x) * 4, 3) != 0)
                        return false;
            return true;
        };
        bool shown = false;
        const auto deadline = Clock::now() + std::chrono::seconds(30);
        while (!shown && Clock::now() < deadline) {
            const iris::Result w = e_->waitForFrame(std::chrono::milliseconds(100));
            QVERIFY2(!w.ok(), "a frame with tiles failing for now counted as complete");
            auto f = e_->readFrame();
            shown = f.ok() && showsPlaceholder(f->image);
        }
        QVERIFY2(shown, "no frame drew the placeholder where a tile failed for now");
        const iris::Result err = e_->error();
        QCOMPARE(err.status(), iris::Status::IoError);
        QVERIFY2(err.message().find("HTTP 503") != std::string::npos, err.message().c_str());

        // The server answers again: the view, unchanged, completes and equals the local frame.
        proxy->setRule({});
        e_->clearError();
        iris::Result drawn(iris::Status::Timeout, "no complete frame in 60 s");
        const auto back = Clock::now();
        while (Clock::now() - back < std::chrono::seconds(60)) {
            drawn = e_->waitForFrame(std::chrono::milliseconds(200));
            if (drawn.ok()) break;
            e_->clearError(); // a read that failed before the server was back: wait on
        }
        QVERIFY2(drawn.ok(), describe(drawn).c_str());
        auto frame = e_->readFrame();
        QVERIFY(frame.ok());
        const DiffStats st = compareImages(frame->image, local->image);
        QVERIFY2(st.differing == 0,
                 saveFailureArtefacts("dicomweb.failing", frame->image, local->image, nullptr).c_str());
        const std::string lines = e_.endTest(TestEngine::ErrorLines::Show);
        QVERIFY2(lines.empty(), lines.c_str());
        e_->close();
    }

    // A slow server, at its slowest: it answers no frame at all while the views move. The API
    // never waits for it (the walk ends while every frame answer is still held back: had a call
    // waited, it would have waited for the proxy's 60 s hold and seen answers), and what a
    // superseded view still had queued is dropped; once the server answers, the last view
    // renders exactly.
    void slowServerViewsKeepMoving() {
        std::string why;
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        proxy->setRule({.fault = FaultProxy::Fault::Hold, .fromFrame = 2});
        const std::string url = through(*proxy, sampleUrl_);
        e_.beginTest();
        const iris::View last = viewWithOrigin(5000, 3000, 1, kW, kH);
        auto expected = render(sampleJpeg_.string(), last, &why);
        QVERIFY2(expected, why.c_str());
        QVERIFY(e_->open(url).ok()); // frame 1 of each instance passes: open succeeds
        proxy->resetCount();
        // A walk along level 0, one field after the other, without waiting for any.
        int walkTiles = 0;
        for (int i = 0; i < 10; ++i) {
            e_->setView(viewWithOrigin(400.0 + 450 * i, 300.0 + 250 * i, 1, kW, kH));
            walkTiles += 3 * 3; // the visible level-0 tiles of each field, at least
        }
        e_->setView(last);
        const int answeredDuringWalk = proxy->frameAnswers();
        proxy->setRule({}); // the server answers from now on
        auto frame = renderView(*e_.engine, last, kW, kH, std::chrono::seconds(60), &why);
        QVERIFY2(frame, why.c_str());
        const DiffStats st = compareImages(frame->image, expected->image);
        QVERIFY2(st.differing == 0,
                 saveFailureArtefacts("dicomweb.slow", frame->image, expected->image, nullptr).c_str());
        const int requests = proxy->frameRequests(), frames = proxy->framesAsked();
        qInfo("%d frame answers during the walk; %d frame requests for %d frames for a walk over %d+ tiles and the "
              "last view",
              answeredDuringWalk, requests, frames, walkTiles);
        QVERIFY2(answeredDuringWalk == 0, "an API call waited on the network");
        // Each field's own tiles (visible and perimeter at two levels) alone are more than this.
        QVERIFY2(frames < walkTiles + 60, "superseded views' requests were not dropped");
        const std::string lines = e_.endTest();
        QVERIFY2(lines.empty(), lines.c_str());
        e_->close();
    }

    // The server goes away in the middle of a walk: tiles fail with a clear error and the
    // engine stays usable; when the server is back, new fields load and the field that failed
    // loads when it is needed again.
    void serverStoppedMidWalk() {
        std::string why;
        e_.beginTest();
        const iris::View first = viewWithOrigin(100, 100, 1, kW, kH);
        const iris::View lost = viewWithOrigin(3000, 1500, 1, kW, kH);
        const iris::View after = viewWithOrigin(4500, 3300, 1, kW, kH);
        std::vector<iris::Frame> expected;
        for (const iris::View& v : {lost, after}) {
            auto f = render(sampleJpeg_.string(), v, &why);
            QVERIFY2(f, why.c_str());
            expected.push_back(*f);
        }
        auto start = render(sampleUrl_, first, &why);
        QVERIFY2(start, why.c_str());
        QVERIFY(server_->stop());
        e_->setView(lost);
        // Bounded: each frame is tried three times within about 1.3 s, then reported.
        const auto deadline = Clock::now() + std::chrono::seconds(30);
        while (e_->error().ok() && Clock::now() < deadline) (void)e_->waitForFrame(std::chrono::milliseconds(100));
        const iris::Result err = e_->error();
        qInfo("with the server stopped: %s", describe(err).c_str());
        QCOMPARE(err.status(), iris::Status::IoError);
        QVERIFY2(err.message().find("Cannot read frame") != std::string::npos, err.message().c_str());
        // Still usable: frames are drawn (incomplete: the failing tiles as the placeholder), views move.
        auto shown = e_->readFrame();
        QVERIFY(shown.ok());
        e_->setView(first);
        QVERIFY2(e_->waitForFrame(std::chrono::seconds(30)).ok(), "the field loaded before the stop is not drawn");

        QVERIFY2(server_->restart(&why), why.c_str());
        e_->clearError();
        for (size_t i = 0; i < 2; ++i) {
            const iris::View& v = i == 0 ? after : lost; // a new field, then the one that failed
            auto f = renderView(*e_.engine, v, kW, kH, std::chrono::seconds(60), &why);
            QVERIFY2(f, why.c_str());
            const DiffStats st = compareImages(f->image, expected[i == 0 ? 1 : 0].image);
            QVERIFY2(
                st.differing == 0,
                saveFailureArtefacts("dicomweb.recovered", f->image, expected[i == 0 ? 1 : 0].image, nullptr).c_str());
        }
        QVERIFY2(e_->error().ok(), describe(e_->error()).c_str());
        const std::string lines = e_.endTest(TestEngine::ErrorLines::Show);
        QVERIFY2(lines.empty(), lines.c_str());
        e_->close();
    }

    // A server that is down behind a gateway (503 for every frame) while the view keeps changing
    // for 6 s: the source backs off as a whole, so a dead server sees a few rounds of at most one
    // request per connection however many views ask for the failed tiles (without that, every
    // view re-sent every failed frame three times: about 90 requests here). The engine keeps
    // drawing, the failure is reported as passing (IoError), and once the server answers again
    // the field that failed loads within the longest back-off, although the view has not moved:
    // its tiles are still needed, so they are tried again (before, only a view change did).
    void unavailableServerBacksOff() {
        std::string why;
        auto proxy = FaultProxy::start(server_->port(), &why);
        QVERIFY2(proxy, why.c_str());
        const std::string url = through(*proxy, sampleUrl_);
        e_.beginTest();
        const iris::View view = viewWithOrigin(3000, 1500, 1, kW, kH);
        const iris::View nudged = viewWithOrigin(3001, 1500, 1, kW, kH); // the same tiles
        auto expected = render(sampleJpeg_.string(), view, &why);
        QVERIFY2(expected, why.c_str());
        // Down before the slide is opened, so that no frame is ever answered (an answer ends
        // the back-off): frame 1 of each instance passes, so open succeeds.
        proxy->setRule({.fault = FaultProxy::Fault::Unavailable, .fromFrame = 2});
        QVERIFY(e_->open(url).ok());
        proxy->resetCount();
        int views = 0;
        const auto downUntil = Clock::now() + std::chrono::seconds(6);
        while (Clock::now() < downUntil) {
            e_->setView(views++ % 2 == 0 ? view : nudged);
            (void)e_->waitForFrame(std::chrono::milliseconds(50));
        }
        const int requests = proxy->frameRequests();
        // The failures are reported (each frame's third attempt ends about 1.3 s in; on a
        // loaded machine the loaders may read it later: wait for it, bounded).
        const auto reportDeadline = Clock::now() + std::chrono::seconds(30);
        while (e_->error().ok() && Clock::now() < reportDeadline)
            (void)e_->waitForFrame(std::chrono::milliseconds(100));
        const iris::Result err = e_->error();
        qInfo("server unavailable for 6 s: %d views, %d frame requests; %s", views, requests, describe(err).c_str());
        QCOMPARE(err.status(), iris::Status::IoError);
        QVERIFY2(err.message().find("HTTP 503") != std::string::npos, err.message().c_str());
        // Back-offs of 0.25, 0.5, 1, 2 and 4 s: five rounds in 6 s, each at most one request on
        // each of the 6 connections.
        QVERIFY2(requests <= 6 * 6, "the unavailable server was not left alone between attempts");
        QVERIFY2(e_->readFrame().ok(), "the engine stopped drawing");

        // The view stays where it is while the server comes back: the tiles that failed in it are
        // still needed, so they are tried again when the back-off ends, without a view change.
        e_->clearError();
        e_->setView(view);
        const auto failDeadline = Clock::now() + std::chrono::seconds(30);
        while (e_->error().ok() && Clock::now() < failDeadline) (void)e_->waitForFrame(std::chrono::milliseconds(100));
        QCOMPARE(e_->error().status(), iris::Status::IoError); // this view's tiles failed too
        proxy->setRule({});
        e_->clearError();
        const auto back = Clock::now();
        // Bounded generously (the longest back-off is 8 s): what is checked is that it loads
        // with no view change at all, not how fast a loaded machine gets there.
        iris::Result drawn(iris::Status::Timeout, "no complete frame in 60 s");
        while (Clock::now() - back < std::chrono::seconds(60)) {
            drawn = e_->waitForFrame(std::chrono::milliseconds(200));
            if (drawn.ok()) break;
            e_->clearError(); // a read that failed before the server was back: wait on
        }
        QVERIFY2(
            drawn.ok(),
            ("the field that failed was not loaded again while the view still needed it: " + describe(drawn)).c_str());
        auto frame = e_->readFrame();
        QVERIFY(frame.ok());
        const double recoveredS = std::chrono::duration<double>(Clock::now() - back).count();
        qInfo("the field loaded %.2f s after the server was back (the longest back-off is 8 s), with no view change",
              recoveredS);
        const DiffStats st = compareImages(frame->image, expected->image);
        QVERIFY2(st.differing == 0,
                 saveFailureArtefacts("dicomweb.backoff", frame->image, expected->image, nullptr).c_str());
        QVERIFY2(e_->error().ok(), describe(e_->error()).c_str());
        const std::string lines = e_.endTest(TestEngine::ErrorLines::Show);
        QVERIFY2(lines.empty(), lines.c_str());
        e_->close();
    }

    // An instance stored in a transfer syntax the engine does not decode (RLE Lossless): open
    // names it, from the first frame's answer.
    void unsupportedTransferSyntax() {
        auto aperio = slidesDir("aperio");
        if (!aperio) QSKIP("no test data");
        std::string why;
        const fs::path out = outDir() / "rle";
        auto native = dicomize(out / "native", *aperio / "CMU-1-Small-Region.svs", "--compression=none", &why);
        QVERIFY2(native, why.c_str());
        // Its smallest file, re-encoded as RLE Lossless into a series of its own.
        fs::path smallest;
        for (const auto& e : fs::directory_iterator(*native))
            if (smallest.empty() || fs::file_size(e.path()) < fs::file_size(smallest)) smallest = e.path();
        DcmRLEEncoderRegistration::registerCodecs();
        DcmFileFormat ff;
        QVERIFY(ff.loadFile(OFFilename(smallest.c_str())).good());
        char uid[100];
        ff.getDataset()->putAndInsertString(DCM_SeriesInstanceUID,
                                            dcmGenerateUniqueIdentifier(uid, SITE_SERIES_UID_ROOT));
        ff.getDataset()->putAndInsertString(DCM_SOPInstanceUID,
                                            dcmGenerateUniqueIdentifier(uid, SITE_INSTANCE_UID_ROOT));
        QVERIFY(ff.getDataset()->chooseRepresentation(EXS_RLELossless, nullptr).good());
        const fs::path rle = out / "rle.dcm";
        QVERIFY(ff.saveFile(OFFilename(rle.c_str()), EXS_RLELossless).good());
        DcmRLEEncoderRegistration::cleanup();
        QVERIFY2(server_->upload(rle, &why), why.c_str());
        CHECKED(expectOpenFails(server_->seriesUrl(rle), {}, iris::Status::UnsupportedFormat,
                                {"transfer syntax 1.2.840.10008.1.2.5", "is not supported", "DICOMweb instance"}));
    }
};

QTEST_GUILESS_MAIN(TestDicomWeb)
#include "tst_dicomweb.moc"
