// AnnotationStore: writers build the next snapshot from the current one by copying the chunk
// and bucket directories (pointers) and replacing only what the call touches, then publish it
// with one pointer swap (core/published.h). See annotation_index.h for the structure.
#include <algorithm>
#include <cmath>
#include <mutex>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "annotations/annotation_index.h"
#include "core/published.h"

namespace iris {

using namespace ann;

std::shared_ptr<const Chunk> ann::makeChunk(std::vector<Entry> entries) {
    auto c = std::make_shared<Chunk>();
    std::vector<RValue> values;
    values.reserve(entries.size());
    for (uint32_t i = 0; i < entries.size(); ++i) {
        c->bounds.expand(entries[i]->bounds);
        values.emplace_back(toBBox(entries[i]->bounds), i);
    }
    c->entries = std::move(entries);
    c->tree = RTree(values.begin(), values.end()); // the range constructor packs (STR)
    return c;
}

namespace {

// Interleaves the bits of two 16-bit cells: the Morton order that groups a batch spatially.
uint32_t morton(uint32_t x, uint32_t y) {
    auto spread = [](uint32_t v) {
        v &= 0xFFFF;
        v = (v | (v << 8)) & 0x00FF00FF;
        v = (v | (v << 4)) & 0x0F0F0F0F;
        v = (v | (v << 2)) & 0x33333333;
        v = (v | (v << 1)) & 0x55555555;
        return v;
    };
    return spread(x) | (spread(y) << 1);
}

// The state a writer edits: shallow copies of the current snapshot's directories.
struct Draft {
    std::vector<std::shared_ptr<const Chunk>> chunks;
    std::vector<std::shared_ptr<const IdBucket>> buckets;
    std::shared_ptr<const ClassTable> classes;
    // Chunks and buckets this draft replaced, as mutable copies not yet frozen.
    std::unordered_map<size_t, std::vector<Entry>> chunkEdits;
    std::unordered_map<size_t, std::shared_ptr<IdBucket>> bucketEdits;
    std::shared_ptr<ClassTable> classEdits;

    std::vector<Entry>& chunkForEdit(size_t i) {
        auto it = chunkEdits.find(i);
        if (it == chunkEdits.end()) it = chunkEdits.emplace(i, chunks[i] ? chunks[i]->entries : std::vector<Entry>{}).first;
        return it->second;
    }
    IdBucket& bucketForEdit(size_t b) {
        auto it = bucketEdits.find(b);
        if (it == bucketEdits.end())
            it = bucketEdits.emplace(b, buckets[b] ? std::make_shared<IdBucket>(*buckets[b]) : std::make_shared<IdBucket>())
                     .first;
        return *it->second;
    }
    ClassTable& classesForEdit() {
        if (!classEdits) classEdits = std::make_shared<ClassTable>(classes ? *classes : ClassTable{});
        return *classEdits;
    }
    // Where `id` lives, or none.
    std::optional<uint32_t> chunkOf(uint64_t id) {
        const size_t b = bucketOf(id);
        const IdBucket* bucket = nullptr;
        if (auto it = bucketEdits.find(b); it != bucketEdits.end()) bucket = it->second.get();
        else bucket = buckets[b].get();
        if (!bucket) return std::nullopt;
        auto it = std::lower_bound(bucket->ids.begin(), bucket->ids.end(), std::make_pair(id, uint32_t(0)));
        if (it == bucket->ids.end() || it->first != id) return std::nullopt;
        return it->second;
    }
    void setId(uint64_t id, uint32_t chunk) {
        auto& ids = bucketForEdit(bucketOf(id)).ids;
        auto it = std::lower_bound(ids.begin(), ids.end(), std::make_pair(id, uint32_t(0)));
        if (it != ids.end() && it->first == id) it->second = chunk;
        else ids.insert(it, {id, chunk});
    }
    void eraseId(uint64_t id) {
        auto& ids = bucketForEdit(bucketOf(id)).ids;
        auto it = std::lower_bound(ids.begin(), ids.end(), std::make_pair(id, uint32_t(0)));
        if (it != ids.end() && it->first == id) ids.erase(it);
    }
};

Entry makeEntry(AnnotationObject o) {
    auto s = std::make_shared<StoredAnnotation>();
    s->bounds = annotationBounds(o);
    s->object = std::move(o);
    if (s->object.kind == AnnotationKind::Polygon) s->fillCache = std::make_shared<AnnotationFillCache>();
    return s;
}

} // namespace

// The functions onChange registered. Calls run under `m`, so a subscription's reset() returns
// only when no call of its function is running or can start.
struct AnnotationSubscription::Registry {
    std::mutex m;
    uint64_t next = 1;
    std::vector<std::pair<uint64_t, std::function<void()>>> fns;
    void notify() {
        std::lock_guard lock(m);
        for (auto& [id, fn] : fns) fn();
    }
};

AnnotationSubscription::AnnotationSubscription(AnnotationSubscription&& o) noexcept
    : registry_(std::move(o.registry_)), id_(std::exchange(o.id_, 0)) {}
AnnotationSubscription& AnnotationSubscription::operator=(AnnotationSubscription&& o) noexcept {
    if (this != &o) {
        reset();
        registry_ = std::move(o.registry_);
        id_ = std::exchange(o.id_, 0);
    }
    return *this;
}
AnnotationSubscription::~AnnotationSubscription() { reset(); }
void AnnotationSubscription::reset() {
    if (auto r = registry_.lock()) {
        std::lock_guard lock(r->m);
        std::erase_if(r->fns, [&](const auto& e) { return e.first == id_; });
    }
    registry_.reset();
    id_ = 0;
}

struct AnnotationStore::Impl {
    std::mutex writers; // serialises writers; readers never take it
    std::shared_ptr<AnnotationSubscription::Registry> listeners = std::make_shared<AnnotationSubscription::Registry>();
    Published<AnnotationSnapshot> current;
    uint64_t nextId = 1;     // under `writers`
    uint64_t generation = 0; // under `writers`: the published snapshot's

    Draft draft() const {
        auto s = current.load();
        const auto& si = s->impl();
        return Draft{si.chunks, si.buckets, si.classes, {}, {}, {}};
    }

    // Freezes the draft into the next snapshot and publishes it.
    void publish(Draft& d) {
        for (auto& [i, entries] : d.chunkEdits) {
            d.chunks[i] = entries.empty() ? nullptr : makeChunk(std::move(entries));
        }
        for (auto& [b, bucket] : d.bucketEdits) d.buckets[b] = bucket->ids.empty() ? nullptr : bucket;
        if (d.classEdits) d.classes = d.classEdits;
        // Trailing empty chunks go (ids never point at them); others stay so indices hold.
        while (!d.chunks.empty() && !d.chunks.back()) d.chunks.pop_back();
        auto impl = std::make_unique<AnnotationSnapshot::Impl>();
        impl->generation = ++generation;
        for (const auto& c : d.chunks) {
            if (!c) continue;
            impl->count += c->entries.size();
            impl->bounds.expand(c->bounds);
        }
        impl->chunks = std::move(d.chunks);
        impl->buckets = std::move(d.buckets);
        impl->classes = std::move(d.classes);
        current.store(std::make_shared<const AnnotationSnapshot>(std::move(impl)));
        listeners->notify();
    }

    // Applies `e` to a fresh draft; nothing is published on error.
    Expected<std::vector<uint64_t>> applyLocked(AnnotationEdit& e) {
        Draft d = draft();
        // Validate everything first: all-or-nothing.
        for (size_t i = 0; i < e.add.size(); ++i) {
            if (std::string p = annotationProblem(e.add[i]); !p.empty())
                return Result(Status::InvalidArgument, "annotation " + std::to_string(i) + " to add: " + p);
        }
        for (size_t i = 0; i < e.update.size(); ++i) {
            if (std::string p = annotationProblem(e.update[i]); !p.empty())
                return Result(Status::InvalidArgument, "annotation " + std::to_string(e.update[i].id) + " to update: " + p);
            if (!d.chunkOf(e.update[i].id))
                return Result(Status::NotFound, "no annotation with id " + std::to_string(e.update[i].id) + " to update");
        }
        for (uint64_t id : e.remove)
            if (!d.chunkOf(id)) return Result(Status::NotFound, "no annotation with id " + std::to_string(id) + " to remove");
        {
            // Each existing object is updated or removed at most once per edit.
            std::unordered_set<uint64_t> touched;
            for (const auto& o : e.update)
                if (!touched.insert(o.id).second)
                    return Result(Status::InvalidArgument, "annotation " + std::to_string(o.id) + " is changed twice in one edit");
            for (uint64_t id : e.remove)
                if (!touched.insert(id).second)
                    return Result(Status::InvalidArgument, "annotation " + std::to_string(id) + " is changed twice in one edit");
        }
        {
            std::unordered_set<uint64_t> fresh;
            for (const auto& o : e.add) {
                if (o.id == 0) continue;
                if (d.chunkOf(o.id) || !fresh.insert(o.id).second)
                    return Result(Status::InvalidArgument, "annotation id " + std::to_string(o.id) + " is already used");
            }
        }
        for (auto& c : e.classes) d.classesForEdit()[c.name] = c;
        for (uint64_t id : e.remove) {
            const uint32_t ci = *d.chunkOf(id);
            auto& entries = d.chunkForEdit(ci);
            std::erase_if(entries, [&](const Entry& x) { return x->object.id == id; });
            d.eraseId(id);
        }
        for (auto& o : e.update) {
            const uint32_t ci = *d.chunkOf(o.id);
            auto& entries = d.chunkForEdit(ci);
            for (auto& x : entries)
                if (x->object.id == o.id) x = makeEntry(std::move(o));
        }
        std::vector<uint64_t> ids;
        ids.reserve(e.add.size());
        uint64_t maxId = nextId - 1;
        for (const auto& o : e.add) maxId = std::max(maxId, o.id);
        uint64_t next = maxId + 1;
        std::vector<Entry> entries;
        entries.reserve(e.add.size());
        for (auto& o : e.add) {
            if (o.id == 0) o.id = next++;
            ids.push_back(o.id);
            if (!o.className.empty() && !(d.classEdits ? d.classEdits->count(o.className) : d.classes && d.classes->count(o.className)))
                d.classesForEdit().emplace(o.className, AnnotationClass{o.className, defaultClassColor(o.className), true});
            entries.push_back(makeEntry(std::move(o)));
        }
        placeNew(d, std::move(entries));
        publish(d);
        nextId = next;
        return ids;
    }

    // Few objects join the last chunk while it has room; a batch is sorted spatially and cut
    // into chunks of its own.
    static void placeNew(Draft& d, std::vector<Entry> entries) {
        if (entries.empty()) return;
        size_t last = d.chunks.size();
        if (last > 0) {
            const size_t have = d.chunkEdits.count(last - 1) ? d.chunkEdits[last - 1].size()
                                : d.chunks[last - 1]                  ? d.chunks[last - 1]->entries.size()
                                                                      : 0;
            if (have + entries.size() <= kChunk) {
                auto& target = d.chunkForEdit(last - 1);
                for (auto& x : entries) {
                    d.setId(x->object.id, uint32_t(last - 1));
                    target.push_back(std::move(x));
                }
                return;
            }
        }
        if (entries.size() > kChunk) {
            Box2 all;
            for (const auto& x : entries) all.expand(x->bounds);
            const double sx = all.width() > 0 ? 65535.0 / all.width() : 0;
            const double sy = all.height() > 0 ? 65535.0 / all.height() : 0;
            std::vector<std::pair<uint32_t, Entry>> keyed;
            keyed.reserve(entries.size());
            for (auto& x : entries) {
                const double cx = (x->bounds.minX + x->bounds.maxX) / 2, cy = (x->bounds.minY + x->bounds.maxY) / 2;
                keyed.emplace_back(morton(uint32_t((cx - all.minX) * sx), uint32_t((cy - all.minY) * sy)), std::move(x));
            }
            std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
            for (size_t i = 0; i < keyed.size(); ++i) entries[i] = std::move(keyed[i].second);
        }
        for (size_t start = 0; start < entries.size(); start += kChunk) {
            const size_t ci = d.chunks.size();
            d.chunks.push_back(nullptr);
            auto& target = d.chunkForEdit(ci);
            for (size_t i = start; i < std::min(entries.size(), start + kChunk); ++i) {
                d.setId(entries[i]->object.id, uint32_t(ci));
                target.push_back(std::move(entries[i]));
            }
        }
    }
};

AnnotationStore::AnnotationStore() : impl_(std::make_unique<Impl>()) {
    auto first = std::make_unique<AnnotationSnapshot::Impl>();
    first->buckets.resize(kBuckets);
    first->classes = std::make_shared<const ClassTable>();
    impl_->current.store(std::make_shared<const AnnotationSnapshot>(std::move(first)));
}
AnnotationStore::~AnnotationStore() = default;

std::shared_ptr<const AnnotationSnapshot> AnnotationStore::snapshot() const { return impl_->current.load(); }

AnnotationSubscription AnnotationStore::onChange(std::function<void()> fn) {
    if (!fn) return {};
    std::lock_guard lock(impl_->listeners->m);
    const uint64_t id = impl_->listeners->next++;
    impl_->listeners->fns.emplace_back(id, std::move(fn));
    return AnnotationSubscription(impl_->listeners, id);
}

Expected<std::vector<uint64_t>> AnnotationStore::apply(AnnotationEdit edit) {
    std::lock_guard lock(impl_->writers);
    return impl_->applyLocked(edit);
}

Expected<uint64_t> AnnotationStore::add(AnnotationObject o) {
    AnnotationEdit e;
    e.add.push_back(std::move(o));
    auto ids = apply(std::move(e));
    if (!ids) return ids.error();
    return ids->front();
}

Expected<std::vector<uint64_t>> AnnotationStore::addBatch(std::vector<AnnotationObject> objects) {
    AnnotationEdit e;
    e.add = std::move(objects);
    return apply(std::move(e));
}

Result AnnotationStore::update(AnnotationObject o) {
    AnnotationEdit e;
    e.update.push_back(std::move(o));
    auto r = apply(std::move(e));
    return r ? Result::success() : r.error();
}

Result AnnotationStore::remove(uint64_t id) {
    AnnotationEdit e;
    e.remove.push_back(id);
    auto r = apply(std::move(e));
    return r ? Result::success() : r.error();
}

void AnnotationStore::clear() {
    std::lock_guard lock(impl_->writers);
    Draft d;
    d.buckets.resize(kBuckets);
    d.classes = std::make_shared<const ClassTable>();
    impl_->publish(d);
}

void AnnotationStore::setClassColor(const std::string& name, Rgba8 color) {
    std::lock_guard lock(impl_->writers);
    Draft d = impl_->draft();
    auto& t = d.classesForEdit();
    auto it = t.find(name);
    if (it == t.end()) it = t.emplace(name, AnnotationClass{name, color, true}).first;
    it->second.color = color;
    impl_->publish(d);
}

void AnnotationStore::setClassVisible(const std::string& name, bool visible) {
    std::lock_guard lock(impl_->writers);
    Draft d = impl_->draft();
    auto& t = d.classesForEdit();
    auto it = t.find(name);
    if (it == t.end()) it = t.emplace(name, AnnotationClass{name, defaultClassColor(name), visible}).first;
    it->second.visible = visible;
    impl_->publish(d);
}

Result AnnotationStore::replaceAll(std::vector<AnnotationObject> objects, std::vector<AnnotationClass> classes) {
    std::lock_guard lock(impl_->writers);
    // Validate against an empty store, so that a failure leaves the current one untouched.
    std::unordered_set<uint64_t> seen;
    for (size_t i = 0; i < objects.size(); ++i) {
        if (std::string p = annotationProblem(objects[i]); !p.empty())
            return Result(Status::InvalidArgument, "annotation " + std::to_string(i) + ": " + p);
        if (objects[i].id != 0 && !seen.insert(objects[i].id).second)
            return Result(Status::InvalidArgument, "annotation id " + std::to_string(objects[i].id) + " is used twice");
    }
    // Built from an empty draft, not from the published snapshot: everything is replaced.
    Draft empty;
    empty.buckets.resize(kBuckets);
    empty.classes = std::make_shared<const ClassTable>();
    AnnotationEdit e;
    e.add = std::move(objects);
    e.classes = std::move(classes);
    for (auto& c : e.classes) empty.classesForEdit()[c.name] = c;
    std::vector<Entry> entries;
    entries.reserve(e.add.size());
    uint64_t maxId = 0;
    for (const auto& o : e.add) maxId = std::max(maxId, o.id);
    uint64_t next = maxId + 1;
    for (auto& o : e.add) {
        if (o.id == 0) o.id = next++;
        if (!o.className.empty() && !empty.classesForEdit().count(o.className))
            empty.classesForEdit().emplace(o.className, AnnotationClass{o.className, defaultClassColor(o.className), true});
        entries.push_back(makeEntry(std::move(o)));
    }
    Impl::placeNew(empty, std::move(entries));
    impl_->publish(empty);
    impl_->nextId = next; // ids restart above the largest loaded one
    return Result::success();
}

} // namespace iris
