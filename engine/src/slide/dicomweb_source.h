// SlideSource over a DICOMweb server: a VL Whole Slide Microscopy series given by its URL,
// http(s)://host[:port]/<prefix>/studies/<StudyUID>/series/<SeriesUID>. docs/DICOM.md
// ("DICOMweb") lists what is asked of the server; docs/ARCHITECTURE.md ("The network source")
// how requests are batched and cancelled.
//
//   * open(): WADO-RS …/series/<uid>/metadata (DICOM JSON) is mapped to levels by the same code
//     as local files (slide/dicom_json.h → dicom::layoutSeries); then frame 1 of every instance
//     the slide uses is fetched, concurrently, to learn its transfer syntax (the metadata does
//     not carry it), and the ICC profile's bulk data when the metadata only points to it.
//   * Frames: WADO-RS …/instances/<SOP>/frames/<a>,<b>,…: the frames of one instance that are
//     wanted at the same time, up to 64 a request, in one request (a server answers a list for
//     little more than one frame), with
//     Accept: multipart/related; type="application/octet-stream"; transfer-syntax=*, so that the
//     server sends each frame as stored (JPEG, JPEG 2000 or native samples) and names its
//     transfer syntax. The answer's parts are checked against the list (one part a frame, in its
//     order, each named by its Content-Location where the server gives one) before any frame is
//     kept: a list answered otherwise, or refused (400/404/…: some servers take single frames
//     only), is asked for again one frame a request, and a server that has refused two lists and
//     answered none is asked for single frames only from then on. Many requests are on the wire
//     at once (net::HttpClient); the frames that arrive are kept, compressed, in an LRU of
//     setFrameStoreBytes() (64 MiB until set; the engine gives it 1/16 of its RAM budget), so
//     that a tile the RAM cache let go of is decoded again without a round trip.
//   * The loaders never wait on the network (SlideSource::prefetch / requestTile): each view's
//     tiles are requested in one batch in the loaders' priority order, and a newer batch drops
//     what is still queued of the older one. A request that fails for a reason that may pass (no
//     connection, a timeout, HTTP 408/429/5xx) is retried twice, 250 ms and 1 s later; after
//     that its frames' failure is reported once and each is fetched again when next asked for.
//   * With NetworkOptions::frameCacheDirectory, every frame that arrives is also kept on disk
//     (net::FrameDiskCache, written by its own thread), keyed by its single-frame WADO-RS URL.
//     A frame found there is neither asked for nor queued: prefetch and requestTile pass over
//     it, readFrame reads it from the disk (on the loader's thread, as a local file is read),
//     and open() takes each instance's first frame, and with it the transfer syntax, from there
//     too, so that a series opened again costs the server its metadata and the frames not kept.
//     A kept frame that cannot be read (evicted by another viewer, damaged) is fetched as usual.
//   * readTile() of a frame that was never requested (iris-encode, readAssociatedImage, a direct
//     caller) requests it first in line and waits for it, bounded by the request timeouts.
//
// Threading: readTile, prefetch and requestTile from any thread; answers are handled on the
// HttpClient's thread. `mutex_` guards the frame table, the queue, the count of requests out
// and what is known of the server (its back-off, whether it takes frame lists);
// `callbackMutex_` the arrival callback, which runs under it so that abandon() is a barrier:
// once it returns the callback never runs again.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "net/frame_disk_cache.h"
#include "net/http_client.h"
#include "slide/dicom_source.h"

namespace iris {

class DicomWebSource final : public dicom::SeriesSource {
public:
    static Expected<std::unique_ptr<SlideSource>> open(const std::string& url, const NetworkOptions& options);
    ~DicomWebSource() override;

    bool readsOverNetwork() const override { return true; }
    // The most bytes of compressed frames kept (at least one frame: the one being read, and the
    // frames the current batch wants that no reader has taken yet, always stay).
    static constexpr uint64_t kDefaultFrameStoreBytes = uint64_t(64) << 20;
    void setFrameStoreBytes(uint64_t bytes);
    // The frame store for an engine's RAM budget: 1/16 of it (compressed frames are about a
    // tenth of the decoded tiles), from 4 MiB to 1 GiB.
    static uint64_t frameStoreBytesFor(uint64_t ramBudgetBytes);
    void prefetch(const std::vector<TileAddress>& tiles, std::function<void()> arrived) override;
    bool requestTile(int level, int64_t tx, int64_t ty) override;
    void abandon() override;

private:
    using FrameKey = uint64_t; // instance << 32 | frame (0-based)
    struct Frame {
        enum class State { Queued, Sent, Ready, Failed };
        State state = State::Queued;
        std::vector<uint8_t> bytes; // Ready: the frame as stored
        Result error;               // Failed
        bool urgent = false;        // a reader waits for it: never dropped by a newer batch
        bool consumed = false; // read since it arrived (Ready frames that were not may not be evicted while wanted)
        bool alone = false;    // asked for in a request of its own (a frame list that held it was not answered right)
        uint64_t wantedBy = 0; // the prefetch batch that last asked for it
        std::list<FrameKey>::iterator lru; // Ready
    };
    // One request on the wire or waiting for its retry: frames of one instance, ascending (its
    // answer's parts come in this order). Its frames are Sent until it ends.
    struct Request {
        size_t instance = 0;
        std::vector<uint32_t> frames; // 0-based
        int attempts = 0;
    };
    // Whether the server takes frame lists: Unknown until a list is answered (Taken) or
    // kListRefusals lists were refused with none answered (Refused: single frames from then on).
    enum class Lists { Unknown, Taken, Refused };
    struct Payload {
        std::vector<uint8_t> bytes;
        std::string transferSyntax;
    };

    DicomWebSource(const NetworkOptions& options, std::string seriesUrl, std::string seriesName)
        : options_(options), seriesUrl_(std::move(seriesUrl)), seriesName_(std::move(seriesName)) {}
    Result readFrame(size_t instance, uint32_t frame, uint8_t* dst, size_t pitch) override;
    void willReadFrames(size_t instance, const std::vector<uint32_t>& frames) override;

    // …/instances/<SOP>/frames/<a>,<b>,… (numbered from 1).
    std::string framesUrl(size_t instance, const std::vector<uint32_t>& frames) const;
    // The frame cache's key of one frame: its single-frame WADO-RS URL.
    std::string diskKey(size_t instance, uint32_t frame) const { return framesUrl(instance, {frame}); }
    // With mutex_ held: `key` is not in frames_ and is kept on disk (no I/O, no string built:
    // the cache's index, by the instance's frames-URL hash continued with the frame number).
    bool onDiskOnly(FrameKey key) const;
    // "Cannot read frame <n> of <instance>: ", which starts every frame's error.
    std::string frameContext(size_t instance, uint32_t frame) const;
    size_t maxFrameBytes(size_t instance) const;
    // The frames in an answer to `q`, checked: HTTP status, content type, the multipart body
    // and its parts against the list (net::checkFrameParts): a failure there is the whole
    // answer's. Then each part on its own (transfer syntax, size): a failure there is its
    // frame's. Errors name no frame (frameContext is put before them).
    Expected<std::vector<Expected<Payload>>> parseFramesAnswer(const Request& q, const net::Response& r) const;
    Result probeTransferSyntaxes();
    void fetchIccProfile(const std::string& uri);

    // With mutex_ held.
    // Sends queued frames while fewer than the connection's limit of requests are out: the
    // first in line, with the frames of its instance next in line (a frame list).
    void pump();
    void send(std::shared_ptr<Request> q, net::HttpClient::Clock::time_point notBefore);
    // A request failed for a reason that may pass (with now = its answer's time): back off.
    void serverFailed(net::HttpClient::Clock::time_point now);
    void storeReady(FrameKey key, Frame& f, std::vector<uint8_t> bytes);
    void evict();
    // On the client's thread.
    void onAnswer(const std::shared_ptr<Request>& q, net::Response&& r);

    const NetworkOptions options_;
    const std::string seriesUrl_;  // …/studies/<uid>/series/<uid>, no trailing '/'
    const std::string seriesName_; // "DICOMweb series <uid> on host:port", for messages

    std::mutex mutex_;
    std::condition_variable landed_; // a frame became Ready or Failed, or the source was abandoned
    std::unordered_map<FrameKey, Frame> frames_;
    std::deque<FrameKey> queue_; // Queued frames in request order (may hold stale keys: pump skips them)
    size_t sent_ = 0;            // requests on the wire or waiting for a retry
    Lists lists_ = Lists::Unknown;
    int listRefusals_ = 0;         // lists refused while lists_ is Unknown
    uint64_t batch_ = 0;           // the newest prefetch batch
    std::list<FrameKey> readyLru_; // Ready frames, most recently used first
    size_t readyBytes_ = 0;
    uint64_t frameStoreBytes_ = kDefaultFrameStoreBytes;
    bool abandoned_ = false;
    // The server as a whole (not one frame) is backed off after a failure that may pass (no
    // connection, a timeout, 408/429/5xx): until quietUntil_ no request is sent (those due are
    // sent then), so a server that is down sees a round of at most one request per connection per
    // back-off, however many frames and views ask. Each failure seen after a quiet period ended
    // doubles the next one (failStreak_), up to kMaxQuiet; any answer resets both. While
    // failStreak_ > 0 a prefetch leaves failed frames failed, so that their failure is read.
    int failStreak_ = 0;
    net::HttpClient::Clock::time_point quietUntil_{};

    std::mutex callbackMutex_; // guards arrived_, held while it runs
    std::function<void()> arrived_;

    std::unique_ptr<net::HttpClient> client_;
    std::shared_ptr<net::FrameDiskCache> disk_; // NetworkOptions::frameCacheDirectory; null without
    // Per instance: …/instances/<SOP>/frames/, every frame URL's start, and its frameCacheHash.
    std::vector<std::string> framesPrefix_;
    std::vector<uint64_t> framesPrefixHash_;
};

// The format table's entry (slide_source.cpp).
Expected<std::unique_ptr<SlideSource>> openDicomWebSource(const std::string& url, const NetworkOptions& options);

} // namespace iris
