// AnnotationLoader: a file read and parsed on a worker thread, published into the store in one
// call only when all of it is good. Progress counts bytes over two passes (reading the file,
// then parsing it): total = 2 × the file's size.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "annotations/format_support.h"
#include "core/thread_name.h"

namespace iris {

struct AnnotationLoader::Impl {
    AnnotationStore& store;
    std::string path;
    Callbacks callbacks;
    Mode mode;
    std::atomic<bool> cancel{false}; // set by cancel(); read (relaxed: no data rides on it) by the worker
    std::mutex doneMutex;
    std::condition_variable doneCv;
    bool done = false; // under doneMutex
    Result result;     // under doneMutex, once done
    std::thread worker;

    Impl(AnnotationStore& s, std::string p, Callbacks c, Mode m) : store(s), path(std::move(p)), callbacks(std::move(c)), mode(m) {}

    Result readFile(std::string& text) {
        std::FILE* f = std::fopen(path.c_str(), "rb");
        if (!f) return Result(errno == ENOENT ? Status::NotFound : Status::IoError, path + ": " + std::strerror(errno));
        std::fseek(f, 0, SEEK_END);
        const long size = std::ftell(f);
        std::fseek(f, 0, SEEK_SET);
        if (size < 0) {
            std::fclose(f);
            return Result(Status::NotAFile, path + ": not a regular file");
        }
        const uint64_t total = uint64_t(size) * 2;
        text.resize(size_t(size));
        size_t done = 0;
        while (done < text.size()) {
            if (cancel.load(std::memory_order_relaxed)) {
                std::fclose(f);
                return Result(Status::Cancelled, "loading " + path + " was cancelled");
            }
            const size_t n = std::fread(text.data() + done, 1, std::min<size_t>(8u << 20, text.size() - done), f);
            if (n == 0) {
                const bool err = std::ferror(f);
                std::fclose(f);
                return Result(Status::IoError, path + (err ? ": read error" : ": the file shrank while it was read"));
            }
            done += n;
            if (callbacks.progress) callbacks.progress(done, total);
        }
        std::fclose(f);
        return {};
    }

    void run() {
        size_t objects = 0;
        Result r = [&]() -> Result {
            std::string text;
            if (Result rr = readFile(text); !rr.ok()) return rr;
            const auto format = detectAnnotationFormat(text);
            if (!format) return Result(Status::UnsupportedFormat, path + ": neither GeoJSON nor XML (by its first character)");
            ReadControl control;
            control.cancel = &cancel;
            const uint64_t size = text.size();
            if (callbacks.progress) control.progress = [&](uint64_t d, uint64_t) { callbacks.progress(size + d, 2 * size); };
            auto doc = *format == AnnotationFormat::GeoJson ? readGeoJson(text, control) : readAsapXml(text, control);
            if (!doc) return Result(doc.error().status(), path + ": " + doc.error().message());
            if (cancel.load(std::memory_order_relaxed)) return Result(Status::Cancelled, "loading " + path + " was cancelled");
            objects = doc->objects.size();
            if (mode == Mode::Replace) {
                if (Result rr = store.replaceAll(std::move(doc->objects), std::move(doc->classes)); !rr.ok())
                    return Result(rr.status(), path + ": " + rr.message());
                return {};
            }
            // Append: the file's ids may be taken already; everything gets fresh ids.
            AnnotationEdit edit;
            edit.add = std::move(doc->objects);
            for (auto& o : edit.add) o.id = 0;
            auto current = store.snapshot();
            for (auto& c : doc->classes) {
                const auto known = current->classes();
                if (std::none_of(known.begin(), known.end(), [&](const AnnotationClass& k) { return k.name == c.name; }))
                    edit.classes.push_back(std::move(c));
            }
            auto ids = store.apply(std::move(edit));
            if (!ids) return Result(ids.error().status(), path + ": " + ids.error().message());
            return {};
        }();
        if (callbacks.finished) callbacks.finished(r, r.ok() ? objects : 0);
        {
            std::lock_guard lock(doneMutex);
            result = std::move(r);
            done = true;
        }
        doneCv.notify_all();
    }
};

AnnotationLoader::AnnotationLoader(AnnotationStore& store, std::string path, Callbacks callbacks, Mode mode)
    : impl_(std::make_unique<Impl>(store, std::move(path), std::move(callbacks), mode)) {
    impl_->worker = std::thread([this] {
        nameThisThread("iris-annotation");
        impl_->run();
    });
}

AnnotationLoader::~AnnotationLoader() {
    cancel();
    if (impl_->worker.joinable()) impl_->worker.join();
}

void AnnotationLoader::cancel() noexcept { impl_->cancel.store(true, std::memory_order_relaxed); }

Result AnnotationLoader::wait() {
    std::unique_lock lock(impl_->doneMutex);
    impl_->doneCv.wait(lock, [&] { return impl_->done; });
    return impl_->result;
}

} // namespace iris
