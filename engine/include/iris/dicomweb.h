// Finding slides on a DICOMweb server: QIDO-RS (PS3.18 10.6) searches for studies and for the
// series of a study, returning plain structs, and the series URL that Engine::open() takes
// for a chosen result. Qt-free; docs/DICOM.md, "Finding slides on a server (QIDO-RS)".
//
//   auto qido = iris::dicomweb::QidoClient::create("https://pacs.example/dicom-web", options);
//   iris::dicomweb::StudyQuery q;
//   q.patientName = "Doe^J*";
//   auto studies = (*qido)->searchStudies(q);             // blocks: call it off the UI thread
//   auto series = (*qido)->searchSeries(studies->items[0].studyInstanceUid);
//   engine.open((*qido)->seriesUrl(studies->items[0].studyInstanceUid, series->items[0].seriesInstanceUid));
//
// Thread safety: every member may be called from any thread, also concurrently; the searches
// block the calling thread until the answer (bounded by NetworkOptions' timeouts). Destroy the
// client only once no search is running (a host that searches on worker threads shares it with
// them, as the demo does with a std::shared_ptr); destroying it ends its connections. Credentials
// go only to the service URL's origin and never into a message or a log line.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "iris/types.h"

namespace iris::dicomweb {

// Study-level search. Empty fields do not filter. Text matches follow DICOM (PS3.4 C.2.2.2):
// '*' any run of characters, '?' one character; Orthanc matches person names without regard
// to case, PatientID and AccessionNumber exactly (wildcards allowed). Components of a person
// name are separated by '^' ("Doe^Jane").
struct StudyQuery {
    std::string patientName;     // PatientName (0010,0010)
    std::string patientId;       // PatientID (0010,0020)
    std::string accessionNumber; // AccessionNumber (0008,0050)
    std::string studyDateFrom;   // StudyDate (0008,0020) range, YYYYMMDD each; either may be empty
    std::string studyDateTo;
    std::string studyDescription; // StudyDescription (0008,1030)
    std::string modality = "SM";  // ModalitiesInStudy (0008,0061); "SM": slide microscopy; empty: any
    uint32_t limit = 50;          // results per page, 1…1000
    uint32_t offset = 0;          // results skipped (page × limit)
};

struct Study {
    std::string studyInstanceUid; // (0020,000D), always a valid UID
    std::string patientName;      // as DICOM JSON's Alphabetic (=Ideographic=Phonetic) groups
    std::string patientId;
    std::string accessionNumber;
    std::string studyDate; // YYYYMMDD as the server wrote it ("" when absent)
    std::string studyTime;
    std::string studyDescription;
    std::vector<std::string> modalities; // ModalitiesInStudy
    int64_t numberOfSeries = -1;         // NumberOfStudyRelatedSeries; -1 when not given
    int64_t numberOfInstances = -1;      // NumberOfStudyRelatedInstances; -1 when not given
};

// Series-level search within one study.
struct SeriesQuery {
    std::string modality; // Modality (0008,0060); empty: any ("SM" for slides only)
    uint32_t limit = 100; // 1…1000
    uint32_t offset = 0;
};

struct Series {
    std::string studyInstanceUid;
    std::string seriesInstanceUid; // (0020,000E), always a valid UID
    std::string modality;
    std::string seriesDescription;
    int64_t seriesNumber = -1;      // as given (IS may be negative); -1 also when not given
    int64_t numberOfInstances = -1; // NumberOfSeriesRelatedInstances; -1 when not given
};

// One page of results; `more` is true when the server has results past this page (the
// client asks for one more than `limit` to know).
template <class T>
struct Page {
    std::vector<T> items;
    bool more = false;
};

class IRIS_API QidoClient {
public:
    // A client for the QIDO-RS service at `serviceUrl` (http(s)://host[:port]/<prefix>, e.g.
    // https://pacs.example/dicom-web; a trailing '/' is ignored). The same rules as a series URL:
    // no credentials in the URL (give them in `options`), plain http:// only for loopback hosts
    // unless NetworkOptions::allowPlainHttp. InvalidArgument naming the defect; NotFound for an
    // unreadable CA file. Nothing is sent before the first search.
    static Expected<std::unique_ptr<QidoClient>> create(const std::string& serviceUrl, const NetworkOptions& options);
    ~QidoClient();
    QidoClient(const QidoClient&) = delete;
    QidoClient& operator=(const QidoClient&) = delete;

    // GET <service>/studies?…. InvalidArgument for a query that cannot be sent (a malformed
    // date, a limit out of range, a control character); the server's refusals as errors naming
    // them (HTTP 401 "refused the credentials given", 403, 404, 5xx; IoError or Timeout for the
    // transport); CorruptData naming the element and field for a malformed answer.
    Expected<Page<Study>> searchStudies(const StudyQuery& query) const;
    // GET <service>/studies/<uid>/series?…; `studyInstanceUid` must be a UID.
    Expected<Page<Series>> searchSeries(const std::string& studyInstanceUid, const SeriesQuery& query = {}) const;

    // <service>/studies/<study>/series/<series>: the URL Engine::open() and IrisSlideView::openSlide() take.
    std::string seriesUrl(const std::string& studyInstanceUid, const std::string& seriesInstanceUid) const;
    // The service URL, normalised (scheme://host:port/prefix, no trailing '/').
    const std::string& serviceUrl() const;

    struct Impl;

private:
    explicit QidoClient(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace iris::dicomweb
