#include "core/tile_map.h"

#include <bit>

namespace iris {

TileMap::Table::Table(size_t capacity)
    : mask(capacity - 1), keys(new std::atomic<uint64_t>[capacity]), vals(new std::atomic<int32_t>[capacity]) {
    for (size_t i = 0; i < capacity; ++i) {
        keys[i].store(kEmpty, std::memory_order_relaxed);
        vals[i].store(-1, std::memory_order_relaxed);
    }
}

namespace {
size_t tableCapacity(uint32_t slots) { return std::bit_ceil(size_t(std::max<uint32_t>(slots, 16)) * 4); }
} // namespace

TileMap::TileMap(uint32_t slotCount)
    : slots_(slotCount), tables_{Table(tableCapacity(slotCount)), Table(tableCapacity(slotCount))}, current_(&tables_[0]) {}

// --- readers ------------------------------------------------------------------------------

const TileMap::Table* TileMap::acquireTable() const {
    for (;;) {
        // seq_cst: pairs with the writer's seq_cst store of current_ and load of readers_ in
        // maybeRebuild(): either the writer sees this reader's count, or this reader sees the
        // new table on its re-check and retries.
        const Table* t = current_.load(std::memory_order_seq_cst);
        const size_t i = size_t(t - tables_);
        readers_[i].fetch_add(1, std::memory_order_seq_cst);
        if (current_.load(std::memory_order_seq_cst) == t) return t;
        readers_[i].fetch_sub(1, std::memory_order_release);
    }
}

void TileMap::releaseTable(const Table* t) const {
    // release: the probes above happen-before the writer reusing this table.
    readers_[size_t(t - tables_)].fetch_sub(1, std::memory_order_release);
}

int TileMap::find(const Table& t, uint64_t key) const {
    size_t i = hash(key) & t.mask;
    for (size_t n = 0; n <= t.mask; ++n, i = (i + 1) & t.mask) {
        // acquire: pairs with insert()'s release store of the key, so vals[i] is the slot
        // written for this key.
        const uint64_t k = t.keys[i].load(std::memory_order_acquire);
        if (k == kEmpty) return -1;
        if (k != key) continue;
        const int32_t v = t.vals[i].load(std::memory_order_relaxed);
        // The position may have been erased and reused between the two loads; a key still in
        // place means v belongs to it.
        if (t.keys[i].load(std::memory_order_acquire) == key) return v;
        return -1;
    }
    return -1;
}

int TileMap::pin(uint64_t key, uint64_t frame) {
    const Table* t = acquireTable();
    const int s = find(*t, key);
    releaseTable(t);
    if (s < 0) return -1;
    Slot& sl = slots_[size_t(s)];
    // seq_cst pair with tryReclaim(): raise the count, then look at the status.
    sl.refs.fetch_add(1, std::memory_order_seq_cst);
    if (sl.status.load(std::memory_order_seq_cst) != uint32_t(Status::Active) ||
        sl.key.load(std::memory_order_acquire) != key) {
        sl.refs.fetch_sub(1, std::memory_order_release);
        return -1;
    }
    sl.lastUsed.store(frame, std::memory_order_relaxed); // an eviction hint only
    return s;
}

void TileMap::unpin(int slot) {
    // release: the caller has seen the GPU finish with the slot (fence); the writer's seq_cst
    // load of refs in tryReclaim() acquires that before it overwrites the slot.
    slots_[size_t(slot)].refs.fetch_sub(1, std::memory_order_release);
}

TileMap::Status TileMap::statusOf(uint64_t key) const {
    const Table* t = acquireTable();
    const int s = find(*t, key);
    releaseTable(t);
    if (s < 0) return Status::Free;
    const Slot& sl = slots_[size_t(s)];
    const auto st = Status(sl.status.load(std::memory_order_acquire));
    return sl.key.load(std::memory_order_acquire) == key ? st : Status::Free;
}

uint32_t TileMap::countActive() const {
    uint32_t n = 0;
    for (const Slot& s : slots_) n += s.status.load(std::memory_order_relaxed) == uint32_t(Status::Active);
    return n;
}

// --- the writer ---------------------------------------------------------------------------

bool TileMap::contains(uint64_t key) const {
    // The writer's own table: no reader count needed (only the writer switches tables).
    return find(*current_.load(std::memory_order_relaxed), key) >= 0;
}

void TileMap::insert(uint64_t key, int slot) {
    maybeRebuild();
    Table& t = *current_.load(std::memory_order_relaxed);
    size_t i = hash(key) & t.mask;
    for (;; i = (i + 1) & t.mask) {
        const uint64_t k = t.keys[i].load(std::memory_order_relaxed);
        if (k == kEmpty || k == kTomb) {
            t.vals[i].store(slot, std::memory_order_relaxed);
            t.keys[i].store(key, std::memory_order_release); // pairs with find()'s acquire
            if (k == kTomb) --tombs_;
            ++live_;
            return;
        }
    }
}

void TileMap::erase(uint64_t key) {
    Table& t = *current_.load(std::memory_order_relaxed);
    size_t i = hash(key) & t.mask;
    for (size_t n = 0; n <= t.mask; ++n, i = (i + 1) & t.mask) {
        const uint64_t k = t.keys[i].load(std::memory_order_relaxed);
        if (k == kEmpty) return;
        if (k == key) {
            t.keys[i].store(kTomb, std::memory_order_release);
            --live_;
            ++tombs_;
            return;
        }
    }
}

void TileMap::maybeRebuild() {
    Table* cur = current_.load(std::memory_order_relaxed);
    const size_t cap = cur->mask + 1;
    if (tombs_ < cap / 4) return;
    Table* spare = cur == &tables_[0] ? &tables_[1] : &tables_[0];
    // seq_cst: pairs with acquireTable(). A reader still probing the spare (it was current
    // before the last rebuild) keeps it busy; rebuild later rather than wait.
    if (readers_[size_t(spare - tables_)].load(std::memory_order_seq_cst) != 0) return;
    for (size_t i = 0; i < cap; ++i) spare->keys[i].store(kEmpty, std::memory_order_relaxed);
    size_t live = 0;
    for (size_t i = 0; i < cap; ++i) {
        const uint64_t k = cur->keys[i].load(std::memory_order_relaxed);
        if (k == kEmpty || k == kTomb) continue;
        size_t j = hash(k) & spare->mask;
        while (spare->keys[j].load(std::memory_order_relaxed) != kEmpty) j = (j + 1) & spare->mask;
        spare->vals[j].store(cur->vals[i].load(std::memory_order_relaxed), std::memory_order_relaxed);
        spare->keys[j].store(k, std::memory_order_relaxed);
        ++live;
    }
    // seq_cst store publishes every entry above to readers that load the new pointer.
    current_.store(spare, std::memory_order_seq_cst);
    live_ = live;
    tombs_ = 0;
}

bool TileMap::tryReclaim(int slot) {
    Slot& s = slots_[size_t(slot)];
    uint32_t expected = uint32_t(Status::Active);
    // seq_cst pair with pin(): flip the status, then look at the count.
    if (!s.status.compare_exchange_strong(expected, uint32_t(Status::Filling), std::memory_order_seq_cst)) return false;
    if (s.refs.load(std::memory_order_seq_cst) != 0) {
        s.status.store(uint32_t(Status::Active), std::memory_order_seq_cst);
        reclaimAborted_ = true;
        return false;
    }
    return true;
}

int TileMap::claimFree(uint64_t key) {
    const uint32_t n = uint32_t(slots_.size());
    for (uint32_t k = 0; k < n; ++k) {
        const uint32_t i = (freeHint_ + k) % n;
        Slot& s = slots_[i];
        // Only the writer moves a slot out of FREE, so a relaxed look is enough.
        if (s.status.load(std::memory_order_relaxed) != uint32_t(Status::Free)) continue;
        s.key.store(key, std::memory_order_release);
        s.status.store(uint32_t(Status::Filling), std::memory_order_release);
        insert(key, int(i));
        freeHint_ = i + 1;
        return int(i);
    }
    return -1;
}

void TileMap::activate(int slot, uint64_t uploadSeq, bool opaque, bool mipsReady) {
    Slot& s = slots_[size_t(slot)];
    s.uploadSeq.store(uploadSeq, std::memory_order_relaxed); // published by the release below
    s.opaque.store(opaque, std::memory_order_relaxed);
    s.mipsReady.store(mipsReady, std::memory_order_relaxed);
    // release: pairs with pin()'s seq_cst (acquiring) status load; the upload's completion,
    // observed by the writer on the timeline semaphore, happens-before a reader drawing it.
    s.status.store(uint32_t(Status::Active), std::memory_order_release);
}

uint64_t TileMap::uploadSeqOf(int slot) const {
    // relaxed: the caller's pin (a seq_cst load that saw ACTIVE) acquired the stamp, and the
    // slot cannot be refilled while it is pinned.
    return slots_[size_t(slot)].uploadSeq.load(std::memory_order_relaxed);
}

bool TileMap::opaqueOf(int slot) const {
    return slots_[size_t(slot)].opaque.load(std::memory_order_relaxed); // as uploadSeqOf
}

bool TileMap::mipsReadyOf(int slot) const { return slots_[size_t(slot)].mipsReady.load(std::memory_order_acquire); }

void TileMap::setMipsReady(int slot) {
    // release: the levels' writes happen-before a reader that loads true (mipsReadyOf).
    slots_[size_t(slot)].mipsReady.store(true, std::memory_order_release);
}

int TileMap::slotOf(uint64_t key) const {
    return find(*current_.load(std::memory_order_relaxed), key); // the writer's own table, as contains()
}

void TileMap::activatePinned(int slot, uint64_t frame, uint64_t uploadSeq, bool opaque) {
    Slot& s = slots_[size_t(slot)];
    s.uploadSeq.store(uploadSeq, std::memory_order_relaxed); // published by the seq_cst store below
    s.opaque.store(opaque, std::memory_order_relaxed);
    s.mipsReady.store(true, std::memory_order_relaxed); // uploaded with its levels
    // The count is raised before the status flips, so the writer's CAS (which needs ACTIVE)
    // can only happen once refs ≥ 1 is visible to its seq_cst load: it backs off.
    s.refs.fetch_add(1, std::memory_order_seq_cst);
    s.lastUsed.store(frame, std::memory_order_relaxed);
    s.status.store(uint32_t(Status::Active), std::memory_order_seq_cst);
}

void TileMap::abandon(int slot) {
    Slot& s = slots_[size_t(slot)];
    erase(s.key.load(std::memory_order_relaxed));
    s.key.store(0, std::memory_order_release);
    s.status.store(uint32_t(Status::Free), std::memory_order_release);
}

} // namespace iris
