#include "slide/dicomweb_source.h"

#include <algorithm>
#include <charconv>
#include <set>

#include "net/multipart.h"
#include "slide/dicom_json.h"

namespace iris {

namespace {

using Clock = net::HttpClient::Clock;

constexpr const char* kFrameAccept = "multipart/related; type=\"application/octet-stream\"; transfer-syntax=*";
constexpr const char* kBulkAccept = "multipart/related; type=\"application/octet-stream\"";
constexpr size_t kMaxMetadataBytes = size_t(512) << 20;
constexpr size_t kMaxIccBytes = size_t(16) << 20;
constexpr int kAttempts = 3;                           // per request, when failures may pass
constexpr size_t kMaxStreams = 64;                     // in flight over HTTP/2
// Frames of one instance asked for in one request (…/frames/a,b,c). A server answers a list
// for about what one frame costs it: Orthanc 1.10 parses the instance for each request, about
// 15 ms for a 10 MB instance on the development machine whether 1 or 64 of its frames are
// asked for. Lists of the same instance asked for at once each pay that again (60 frames as
// six concurrent lists of 10: 87 ms; as one list: 16 ms), so the frames of an instance that
// are queued together go in one list, up to kMaxBatch; the connections serve several
// instances (a field's LR and HR levels, level 0 split over files) at once.
constexpr size_t kMaxBatch = 64;
// Frame lists refused (4xx, 501, a broken answer) before any was answered: the server takes
// single frames only, and is asked for one frame a request from then on.
constexpr int kListRefusals = 2;

// Back-off before attempt n + 1 (n ≥ 1) of one frame.
std::chrono::milliseconds backoff(int attempts) { return std::chrono::milliseconds(attempts <= 1 ? 250 : 1000); }

// The server's back-off after `streak` failures in a row that may pass (streak ≥ 1): 250 ms,
// doubling, at most kMaxQuiet.
constexpr std::chrono::milliseconds kFirstQuiet{250};
constexpr std::chrono::milliseconds kMaxQuiet{8000};
std::chrono::milliseconds quietAfter(int streak) {
    const int doublings = std::min(streak - 1, 6); // 250 ms << 6 = 16 s > kMaxQuiet
    return std::min(kFirstQuiet * (1 << doublings), kMaxQuiet);
}

// A frame list that this server may not take (some answer 400 or 404 to any list, or 501).
bool refusesList(const net::Response& r) {
    return r.error.ok() && (r.status == 400 || r.status == 404 || r.status == 406 || r.status == 415 ||
                            r.status == 422 || r.status == 501);
}

// Whether a failed request may succeed when tried again soon.
bool passing(const net::Response& r) {
    if (!r.error.ok()) return r.error.status() == Status::IoError || r.error.status() == Status::Timeout;
    return r.status == 408 || r.status == 429 || (r.status >= 500 && r.status <= 599);
}

// The transfer syntax of a frame: its part's Content-Type parameter; else the message's
// transfer-syntax parameter, or one inside its type parameter (Orthanc writes
// type="image/jpeg; transfer-syntax=…"); else what the media type implies (PS3.18 8.7.3.5.2).
std::string transferSyntaxOf(const net::MediaType* part, const net::MediaType& message) {
    if (part) {
        if (const std::string* ts = part->param("transfer-syntax")) return *ts;
    }
    if (const std::string* ts = message.param("transfer-syntax")) return *ts;
    if (const std::string* type = message.param("type")) {
        if (auto inner = net::parseMediaType(*type); inner.ok()) {
            if (const std::string* ts = inner->param("transfer-syntax")) return *ts;
        }
    }
    const std::string type = part ? part->type : std::string();
    if (type == "application/octet-stream" || type.empty()) return "1.2.840.10008.1.2.1";
    if (type == "image/jpeg") return "1.2.840.10008.1.2.4.50";
    if (type == "image/jp2" || type == "image/jpx") return "1.2.840.10008.1.2.4.90";
    return {};
}

} // namespace

Expected<std::unique_ptr<SlideSource>> openDicomWebSource(const std::string& url, const NetworkOptions& options) {
    return DicomWebSource::open(url, options);
}

Expected<std::unique_ptr<SlideSource>> DicomWebSource::open(const std::string& text, const NetworkOptions& options) {
    auto url = net::parseUrl(text);
    if (!url.ok()) return url.error();
    if (url->scheme == "http" && !url->loopback() && !options.allowPlainHttp) {
        return Result(Status::InvalidArgument,
                      "Cannot open '" + text +
                          "': plain http:// is only used for loopback hosts (pixels and "
                          "credentials would cross the network unencrypted); use https://, or set "
                          "NetworkOptions::allowPlainHttp");
    }
    // …/studies/<StudyUID>/series/<SeriesUID>[/]
    std::vector<std::string> segments;
    for (size_t i = 0; i < url->path.size();) {
        const size_t j = std::min(url->path.find('/', i), url->path.size());
        if (j > i) segments.push_back(url->path.substr(i, j - i));
        i = j + 1;
    }
    const size_t n = segments.size();
    if (n < 4 || segments[n - 4] != "studies" || segments[n - 2] != "series" || !dicom::isUid(segments[n - 3]) ||
        !dicom::isUid(segments[n - 1])) {
        return Result(Status::InvalidArgument, "Cannot open '" + text +
                                                   "': a DICOMweb series URL ends in "
                                                   "/studies/<Study Instance UID>/series/<Series Instance UID>");
    }
    std::string seriesUrl = url->scheme + "://" + url->host + ":" + std::to_string(url->port);
    for (const std::string& s : segments) seriesUrl += "/" + s;
    const std::string seriesUid = segments[n - 1];
    const std::string seriesName =
        "DICOMweb series " + seriesUid + " on " + url->host + ":" + std::to_string(url->port);
    std::unique_ptr<DicomWebSource> src(new DicomWebSource(options, seriesUrl, seriesName));
    auto client = net::HttpClient::create(options, *url);
    if (!client.ok()) return client.error();
    src->client_ = std::move(*client);
    const bool credentials = !options.username.empty() || !options.bearerToken.empty();

    std::string cacheError;
    if (!options.frameCacheDirectory.empty()) {
        // Frames are kept for later only: a folder that cannot be used costs that, not the slide.
        auto disk = net::FrameDiskCache::open(options.frameCacheDirectory, options.frameCacheBytes);
        if (disk.ok())
            src->disk_ = std::move(*disk);
        else
            cacheError = disk.error().message();
    }

    const std::string context = "Cannot open " + seriesName + ": ";
    const net::Response meta =
        src->client_->getNow(seriesUrl + "/metadata", "application/dicom+json", kMaxMetadataBytes);
    if (!meta.error.ok()) return Result(meta.error.status(), context + meta.error.message());
    if (meta.status != 200) return net::httpError(meta.status, context, "the series", credentials);
    const auto type = net::parseMediaType(meta.contentType);
    if (!type.ok() || (type->type != "application/dicom+json" && type->type != "application/json")) {
        return Result(Status::UnsupportedFormat, context + "the server answered with Content-Type '" +
                                                     meta.contentType.substr(0, 100) +
                                                     "', not DICOM JSON (is this a DICOMweb series URL?)");
    }
    auto series = dicom::describeJsonSeries(meta.body.data(), meta.body.size(), seriesUid, seriesName);
    if (!series.ok()) return series.error();
    src->instances_ = std::move(series->instances);
    src->layout_ = std::move(series->layout);
    for (const dicom::InstanceDescription& in : src->instances_) {
        src->framesPrefix_.push_back(seriesUrl + "/instances/" + in.sopInstanceUid + "/frames/");
        src->framesPrefixHash_.push_back(net::frameCacheHash(src->framesPrefix_.back()));
    }
    if (Result r = src->probeTransferSyntaxes(); !r.ok()) return r;
    dicom::SeriesMetadata& metadata = series->metadata;
    if (metadata.iccProfile.empty() && !metadata.iccBulkDataUri.empty()) {
        auto icc = src->client_->getNow(metadata.iccBulkDataUri.rfind("/", 0) == 0
                                            ? url->scheme + "://" + url->host + ":" + std::to_string(url->port) +
                                                  metadata.iccBulkDataUri
                                            : metadata.iccBulkDataUri,
                                        kBulkAccept, kMaxIccBytes);
        // The profile is not needed to show the slide: a failure is kept as a property.
        std::string why;
        if (!icc.error.ok()) {
            why = icc.error.message();
        } else if (icc.status != 200) {
            why = net::httpError(icc.status, "", "the ICC profile", credentials).message();
        } else if (auto parts = net::parseMultipart(icc.contentType, icc.body.data(), icc.body.size()); !parts.ok()) {
            why = parts.error().message();
        } else {
            metadata.iccProfile.assign(parts->front().data, parts->front().data + parts->front().size);
        }
        if (!why.empty()) metadata.properties["dicomweb.ICCProfileError"] = why;
    }
    if (!cacheError.empty()) metadata.properties["dicomweb.FrameCacheError"] = cacheError;
    dicom::fillSlideInfo(src->instances_, src->layout_, metadata, &src->info_);
    src->info_.path = text;
    return std::unique_ptr<SlideSource>(std::move(src));
}

DicomWebSource::~DicomWebSource() {
    abandon();
    client_.reset(); // joins the client's thread: no answer is handled after this
}

std::string DicomWebSource::framesUrl(size_t instance, const std::vector<uint32_t>& frames) const {
    std::string url = framesPrefix_[instance];
    for (size_t i = 0; i < frames.size(); ++i) {
        if (i) url += ',';
        url += std::to_string(frames[i] + 1);
    }
    return url;
}

std::string DicomWebSource::frameContext(size_t instance, uint32_t frame) const {
    return "Cannot read frame " + std::to_string(frame + 1) + " of " + instances_[instance].name + ": ";
}

size_t DicomWebSource::maxFrameBytes(size_t instance) const {
    // A compressed frame is smaller than its samples; twice that and a margin for the
    // multipart headers bounds any honest answer.
    const dicom::InstanceDescription& in = instances_[instance];
    return size_t(in.frameW) * in.frameH * std::max<uint32_t>(in.samplesPerPixel, 1) * 2 + (size_t(1) << 20);
}

Expected<std::vector<Expected<DicomWebSource::Payload>>>
DicomWebSource::parseFramesAnswer(const Request& q, const net::Response& r) const {
    const dicom::InstanceDescription& in = instances_[q.instance];
    if (!r.error.ok()) return r.error;
    if (r.status != 200) {
        const bool credentials = !options_.username.empty() || !options_.bearerToken.empty();
        return net::httpError(r.status, "", "the frame", credentials);
    }
    const auto message = net::parseMediaType(r.contentType);
    if (!message.ok() || message->type != "multipart/related") {
        return Result(Status::CorruptData, "the server answered with Content-Type '" + r.contentType.substr(0, 100) +
                                               "', not multipart/related");
    }
    auto parts = net::parseMultipart(r.contentType, r.body.data(), r.body.size());
    if (!parts.ok()) return Result(Status::CorruptData, parts.error().message());
    std::vector<uint32_t> numbers; // as the request named them: from 1
    numbers.reserve(q.frames.size());
    for (const uint32_t f : q.frames) numbers.push_back(f + 1);
    if (Result c = net::checkFrameParts(*parts, numbers); !c.ok()) return c;
    // Each part on its own: a defect here is that frame's, not its neighbours'.
    std::vector<Expected<Payload>> out;
    out.reserve(parts->size());
    for (const net::Part& part : *parts) {
        std::optional<net::MediaType> partType;
        if (!part.contentType.empty()) {
            auto t = net::parseMediaType(part.contentType);
            if (!t.ok()) {
                out.emplace_back(Result(Status::CorruptData, "its part's " + t.error().message()));
                continue;
            }
            partType = std::move(*t);
        }
        Payload p;
        p.transferSyntax = transferSyntaxOf(partType ? &*partType : nullptr, *message);
        if (p.transferSyntax.empty()) {
            out.emplace_back(Result(Status::UnsupportedFormat, "the frame came as '" + part.contentType.substr(0, 100) +
                                                                   "' without a transfer syntax"));
        } else if (!in.transferSyntax.empty() && p.transferSyntax != in.transferSyntax) {
            out.emplace_back(Result(Status::CorruptData, "it came in transfer syntax " +
                                                             p.transferSyntax.substr(0, 64) +
                                                             ", the instance's first frame in " + in.transferSyntax));
        } else if (part.size == 0 || part.size > maxFrameBytes(q.instance)) {
            out.emplace_back(Result(Status::CorruptData, "its part holds " + std::to_string(part.size) +
                                                             " bytes, which no frame of " + std::to_string(in.frameW) +
                                                             "×" + std::to_string(in.frameH) + " has"));
        } else {
            p.bytes.assign(part.data, part.data + part.size);
            out.emplace_back(std::move(p));
        }
    }
    return out;
}

Result DicomWebSource::probeTransferSyntaxes() {
    // Every instance the slide draws from: the levels' frames and the associated images.
    std::set<size_t> used;
    for (const dicom::Level& L : layout_.levels)
        for (const dicom::Level::Cell& c : L.cells)
            if (c.instance >= 0) used.insert(size_t(c.instance));
    for (const auto& a : layout_.associated) used.insert(a.second);
    // An instance whose first frame is kept on disk needs no request: the file names the
    // transfer syntax the server sent it in.
    std::vector<std::pair<size_t, Payload>> kept;
    if (disk_) {
        for (auto it = used.begin(); it != used.end();) {
            if (auto f = disk_->get(diskKey(*it, 0), {})) {
                kept.emplace_back(*it, Payload{std::move(f->bytes), std::move(f->transferSyntax)});
                it = used.erase(it);
            } else {
                ++it;
            }
        }
    }
    std::mutex m;
    std::condition_variable done;
    size_t pending = used.size();
    std::vector<std::pair<size_t, net::Response>> answers;
    for (size_t i : used) {
        client_->get(framesUrl(i, {0}), kFrameAccept, maxFrameBytes(i), [&, i](net::Response&& r) {
            std::lock_guard lock(m);
            answers.emplace_back(i, std::move(r));
            if (--pending == 0) done.notify_all();
        });
    }
    {
        std::unique_lock lock(m);
        done.wait(lock, [&] { return pending == 0; }); // every request is answered, at the latest by its timeout
    }
    std::vector<std::pair<size_t, Expected<Payload>>> payloads;
    for (auto& [i, p] : kept) payloads.emplace_back(i, std::move(p));
    for (auto& [i, r] : answers) {
        auto parsed = parseFramesAnswer(Request{.instance = i, .frames = {0}}, r);
        payloads.emplace_back(i, parsed.ok() ? std::move(parsed->front()) : Expected<Payload>(parsed.error()));
        if (disk_ && payloads.back().second.ok()) {
            const Payload& p = *payloads.back().second;
            disk_->put(diskKey(i, 0), {p.transferSyntax, p.bytes});
        }
    }
    std::sort(payloads.begin(), payloads.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (auto& [i, payload] : payloads) {
        if (!payload.ok()) {
            const Result& e = payload.error();
            return Result(e.status(), "Cannot open " + seriesName_ + ": " + frameContext(i, 0) + e.message());
        }
        if (Result c = dicom::choosePixelFormat(instances_[i], payload->transferSyntax); !c.ok()) return c;
        // The frame itself is kept: it is one the slide shows.
        std::lock_guard lock(mutex_);
        const FrameKey key = FrameKey(i) << 32;
        Frame& f = frames_[key];
        storeReady(key, f, std::move(payload->bytes));
    }
    return {};
}

bool DicomWebSource::onDiskOnly(FrameKey key) const {
    if (!disk_ || frames_.count(key)) return false;
    char number[16];
    const auto end = std::to_chars(number, number + sizeof number, (key & 0xffffffffu) + 1).ptr; // from 1
    const size_t instance = size_t(key >> 32);
    return disk_->contains(
        net::frameCacheHash(std::string_view(number, size_t(end - number)), framesPrefixHash_[instance]));
}

void DicomWebSource::storeReady(FrameKey key, Frame& f, std::vector<uint8_t> bytes) {
    if (f.state == Frame::State::Ready) {
        readyBytes_ -= f.bytes.size();
        readyLru_.erase(f.lru);
    }
    f.state = Frame::State::Ready;
    f.bytes = std::move(bytes);
    f.error = {};
    f.consumed = false;
    readyLru_.push_front(key);
    f.lru = readyLru_.begin();
    readyBytes_ += f.bytes.size();
    evict();
}

void DicomWebSource::setFrameStoreBytes(uint64_t bytes) {
    std::lock_guard lock(mutex_);
    frameStoreBytes_ = bytes;
    evict();
}

uint64_t DicomWebSource::frameStoreBytesFor(uint64_t ramBudgetBytes) {
    return std::clamp<uint64_t>(ramBudgetBytes / 16, uint64_t(4) << 20, uint64_t(1) << 30);
}

void DicomWebSource::evict() {
    // Oldest first; a frame nobody has read yet stays when the current batch wants it or a
    // reader waits for it (else a store smaller than the frames in flight would evict a frame
    // before its reader wakes, and the reader would ask for it again, and again).
    for (auto it = readyLru_.end(); readyBytes_ > frameStoreBytes_ && it != readyLru_.begin();) {
        --it;
        auto f = frames_.find(*it);
        if (f == frames_.end()) {
            it = readyLru_.erase(it);
            continue;
        }
        if (!f->second.consumed && (f->second.urgent || (f->second.wantedBy == batch_ && batch_ != 0))) continue;
        readyBytes_ -= f->second.bytes.size();
        it = readyLru_.erase(it);
        frames_.erase(f);
    }
}

void DicomWebSource::serverFailed(Clock::time_point now) {
    // Failures of requests sent in one round (several connections) arrive together: only the
    // first one after the quiet period ended lengthens the next.
    if (now < quietUntil_) return;
    ++failStreak_;
    quietUntil_ = now + quietAfter(failStreak_);
}

void DicomWebSource::send(std::shared_ptr<Request> q, Clock::time_point notBefore) {
    notBefore = std::max(notBefore, quietUntil_); // nothing reaches a server that is backed off
    size_t maxBytes = 0;
    for (size_t i = 0; i < q->frames.size(); ++i) maxBytes += maxFrameBytes(q->instance);
    std::string url = framesUrl(q->instance, q->frames);
    client_->get(
        std::move(url), kFrameAccept, maxBytes, [this, q](net::Response&& r) { onAnswer(q, std::move(r)); }, notBefore);
}

void DicomWebSource::pump() {
    const size_t limit = client_->multiplexing() ? kMaxStreams : std::max<size_t>(1, options_.maxConnections);
    const auto queued = [this](FrameKey key) {
        const auto it = frames_.find(key);
        return it != frames_.end() && it->second.state == Frame::State::Queued;
    };
    while (sent_ < limit) {
        while (!queue_.empty() && !queued(queue_.front())) queue_.pop_front(); // stale: sent or dropped
        if (queue_.empty()) return;
        const FrameKey head = queue_.front();
        queue_.pop_front();
        auto q = std::make_shared<Request>();
        q->instance = size_t(head >> 32);
        Frame& first = frames_[head];
        first.state = Frame::State::Sent;
        q->frames.push_back(uint32_t(head & 0xffffffffu));
        if (lists_ != Lists::Refused && !first.alone) {
            // The frames of the same instance next in line join it, in queue order, at most
            // kMaxBatch in all.
            for (auto it = queue_.begin(); it != queue_.end() && q->frames.size() < kMaxBatch;) {
                const auto f = frames_.find(*it);
                if (size_t(*it >> 32) == q->instance && f != frames_.end() && f->second.state == Frame::State::Queued &&
                    !f->second.alone) {
                    f->second.state = Frame::State::Sent;
                    q->frames.push_back(uint32_t(*it & 0xffffffffu));
                    it = queue_.erase(it);
                } else {
                    ++it;
                }
            }
            std::sort(q->frames.begin(), q->frames.end()); // the answer's parts come in this order
        }
        ++sent_;
        send(std::move(q), {});
    }
}

void DicomWebSource::onAnswer(const std::shared_ptr<Request>& q, net::Response&& r) {
    // Parsed outside the lock: the multipart body is scanned and the frames copied.
    auto answer = parseFramesAnswer(*q, r);
    const bool list = q->frames.size() > 1;
    bool landed = false;
    std::vector<std::pair<std::string, net::FrameDiskCache::Frame>> keep; // on disk, after the lock
    {
        std::lock_guard lock(mutex_);
        if (abandoned_) return;
        const auto frame = [&](uint32_t f) -> Frame* {
            const auto it = frames_.find((FrameKey(q->instance) << 32) | f);
            return it == frames_.end() ? nullptr : &it->second; // null cannot happen: a frame on the wire stays
        };
        const bool refused = !answer.ok() && list && refusesList(r);
        const bool mayPass = !answer.ok() && !refused && passing(r);
        if (mayPass) {
            serverFailed(Clock::now());
        } else {
            // Any answer (even a 404 or a broken body) says the server is there.
            failStreak_ = 0;
            quietUntil_ = {};
        }
        if (mayPass && ++q->attempts < kAttempts) {
            send(q, Clock::now() + backoff(q->attempts)); // still counted in sent_
            return;
        }
        --sent_;
        if (!answer.ok() && list && !mayPass) {
            // A list refused, or answered with parts that are not the frames asked for (fewer,
            // more, out of order, a broken body): each of its frames is asked for alone, first
            // in line, and gets an answer of its own. A server that has never answered a list
            // is taken to refuse them after kListRefusals of these.
            if (lists_ == Lists::Unknown && ++listRefusals_ >= kListRefusals) lists_ = Lists::Refused;
            for (auto f = q->frames.rbegin(); f != q->frames.rend(); ++f) {
                Frame* fr = frame(*f);
                if (!fr) continue;
                fr->state = Frame::State::Queued;
                fr->alone = true;
                queue_.push_front((FrameKey(q->instance) << 32) | *f);
            }
        } else {
            if (answer.ok() && list) lists_ = Lists::Taken;
            for (size_t i = 0; i < q->frames.size(); ++i) {
                Frame* fr = frame(q->frames[i]);
                if (!fr) continue;
                Expected<Payload>* part = answer.ok() ? &(*answer)[i] : nullptr;
                if (part && part->ok()) {
                    if (disk_)
                        keep.emplace_back(diskKey(q->instance, q->frames[i]),
                                          net::FrameDiskCache::Frame{(*part)->transferSyntax, (*part)->bytes});
                    storeReady((FrameKey(q->instance) << 32) | q->frames[i], *fr, std::move((*part)->bytes));
                } else {
                    const Result& e = part ? part->error() : answer.error();
                    fr->state = Frame::State::Failed;
                    fr->error = Result(e.status(), frameContext(q->instance, q->frames[i]) + e.message());
                }
            }
            landed = true;
            landed_.notify_all();
        }
        pump();
    }
    for (auto& [key, frame] : keep) disk_->put(key, std::move(frame));
    if (!landed) return;
    std::lock_guard lock(callbackMutex_);
    if (arrived_) arrived_();
}

void DicomWebSource::prefetch(const std::vector<TileAddress>& tiles, std::function<void()> arrived) {
    {
        std::lock_guard lock(callbackMutex_);
        std::lock_guard state(mutex_);
        if (abandoned_) return;
        arrived_ = std::move(arrived);
    }
    std::lock_guard lock(mutex_);
    if (abandoned_) return;
    const uint64_t batch = ++batch_;
    // While the server fails (it has not answered since a failure that may pass) a failed frame
    // stays failed: the loaders read its failure (reported, then forgotten: the next view that
    // needs it asks again, sent when the back-off ends). Queued again at once, it would wait
    // unreported for the end of the back-off; and queued again by each view change before a
    // loader read it (views change faster than a loaded machine's loaders may get to a
    // failure; a back-off can end meanwhile), it would never be reported at all. Once the server
    // has answered again, a failure seen while it was down is stale: the frame is asked again.
    const bool failing = failStreak_ > 0;
    std::vector<FrameKey> order;
    for (const TileAddress& t : tiles) {
        for (const uint64_t cell : cellsOfTile(t.level, t.tx, t.ty)) {
            const dicom::Level::Cell& c = layout_.levels[size_t(t.level)].cells[size_t(cell)];
            if (c.instance < 0 || hasDecodedFrame(size_t(t.level), cell)) continue;
            const FrameKey key = (FrameKey(c.instance) << 32) | c.frame;
            if (onDiskOnly(key)) continue; // readFrame takes it from the disk
            auto [it, inserted] = frames_.try_emplace(key);
            Frame& f = it->second;
            if (!inserted && f.wantedBy == batch) continue; // a frame several tiles share
            f.wantedBy = batch;
            if (inserted || f.state == Frame::State::Queued) {
                order.push_back(key);
            } else if (f.state == Frame::State::Failed && !failing) { // needed again: try again
                f.state = Frame::State::Queued;
                f.error = {};
                order.push_back(key);
            }
        }
    }
    // The new queue: frames a reader waits for first, then this batch in its order. Queued
    // frames of earlier batches that this one does not want are dropped.
    std::deque<FrameKey> next;
    for (const FrameKey key : queue_) {
        const auto it = frames_.find(key);
        if (it == frames_.end() || it->second.state != Frame::State::Queued) continue;
        if (it->second.urgent)
            next.push_back(key);
        else if (it->second.wantedBy != batch)
            frames_.erase(it);
    }
    for (const FrameKey key : order)
        if (!frames_[key].urgent) next.push_back(key);
    queue_.swap(next);
    pump();
}

bool DicomWebSource::requestTile(int level, int64_t tx, int64_t ty) {
    const std::vector<uint64_t> cells = cellsOfTile(level, tx, ty);
    std::lock_guard lock(mutex_);
    if (abandoned_) return true; // readTile answers Cancelled at once
    bool ready = true;
    for (const uint64_t cell : cells) {
        const dicom::Level::Cell& c = layout_.levels[size_t(level)].cells[size_t(cell)];
        if (c.instance < 0 || hasDecodedFrame(size_t(level), cell)) continue;
        const FrameKey key = (FrameKey(c.instance) << 32) | c.frame;
        if (onDiskOnly(key)) continue; // ready: readFrame takes it from the disk
        auto [it, inserted] = frames_.try_emplace(key);
        Frame& f = it->second;
        if (inserted) {
            f.wantedBy = batch_;
            queue_.push_back(key);
        }
        ready = ready && (f.state == Frame::State::Ready || f.state == Frame::State::Failed);
    }
    if (!ready) pump();
    return ready;
}

void DicomWebSource::willReadFrames(size_t instance, const std::vector<uint32_t>& frames) {
    std::lock_guard lock(mutex_);
    if (abandoned_) return;
    for (auto f = frames.rbegin(); f != frames.rend(); ++f) { // the first frame ends up first in line
        const FrameKey key = (FrameKey(instance) << 32) | *f;
        if (onDiskOnly(key)) continue;
        auto [it, inserted] = frames_.try_emplace(key);
        it->second.urgent = true;
        if (inserted || it->second.state == Frame::State::Queued) queue_.push_front(key);
    }
    pump();
}

Result DicomWebSource::readFrame(size_t instance, uint32_t frame, uint8_t* dst, size_t pitch) {
    const FrameKey key = (FrameKey(instance) << 32) | frame;
    if (disk_) {
        // A frame not in memory is read from the disk when it is kept there (on this, the
        // loader's, thread); a miss (evicted, damaged) is fetched below as any other.
        bool fromDisk = false;
        {
            std::lock_guard lock(mutex_);
            if (abandoned_) return Result(Status::Cancelled, "The slide was closed");
            fromDisk = onDiskOnly(key);
        }
        if (fromDisk) {
            if (auto f = disk_->get(diskKey(instance, frame), instances_[instance].transferSyntax))
                return dicom::decodeFrame(instances_[instance], frame, f->bytes.data(), f->bytes.size(), dst, pitch);
        }
    }
    thread_local std::vector<uint8_t> bytes;
    {
        std::unique_lock lock(mutex_);
        // Each attempt is bounded by the request timeout; the last waits at most that long after
        // its back-off, and the server's back-off delays each at most kMaxQuiet. A server that
        // never answers cannot hold a reader longer than this.
        const auto deadline =
            std::max(Clock::now(), quietUntil_) + kMaxQuiet +
            kAttempts * std::chrono::milliseconds(options_.connectTimeoutMs + options_.requestTimeoutMs) +
            std::chrono::seconds(2);
        for (;;) {
            if (abandoned_) return Result(Status::Cancelled, "The slide was closed");
            auto it = frames_.find(key);
            if (it == frames_.end()) { // never asked for: first in line, and wait
                it = frames_.try_emplace(key).first;
                it->second.urgent = true;
                it->second.wantedBy = batch_;
                queue_.push_front(key);
                pump();
            }
            Frame& f = it->second;
            if (f.state == Frame::State::Ready) {
                bytes = f.bytes;
                f.consumed = true;
                readyLru_.splice(readyLru_.begin(), readyLru_, f.lru);
                // Frames kept over the budget for their readers may go now (this one too: its
                // bytes are copied).
                if (readyBytes_ > frameStoreBytes_) evict();
                break;
            }
            if (f.state == Frame::State::Failed) {
                Result error = f.error;
                // A failure that may pass is reported once; the next read asks again.
                const Status s = error.status();
                if (s == Status::IoError || s == Status::Timeout || s == Status::Cancelled) frames_.erase(it);
                return error;
            }
            if (f.state == Frame::State::Queued && !f.urgent) { // now first in line
                f.urgent = true;
                queue_.push_front(key);
                pump();
            }
            f.urgent = true;
            if (landed_.wait_until(lock, deadline) == std::cv_status::timeout && Clock::now() >= deadline) {
                return Result(Status::Timeout, "Cannot read frame " + std::to_string(frame + 1) + " of " +
                                                   instances_[instance].name + ": no answer from " + seriesName_ +
                                                   " in time");
            }
        }
    }
    return dicom::decodeFrame(instances_[instance], frame, bytes.data(), bytes.size(), dst, pitch);
}

void DicomWebSource::abandon() {
    {
        std::lock_guard lock(callbackMutex_);
        arrived_ = nullptr;
    }
    {
        std::lock_guard lock(mutex_);
        if (abandoned_) return;
        abandoned_ = true;
        queue_.clear();
        landed_.notify_all();
    }
    if (client_) client_->cancelAll();
}

} // namespace iris
