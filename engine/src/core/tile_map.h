// The tile map: which slot of the GPU tile atlas holds which tile, readable without locks or
// waits. A CPU structure (core/, not gpu/): the atlas owns one, the buffer and render threads
// share it.
//
// Slots: a fixed array sized at startup. Each slot has an atomic key, an atomic status
// (FREE → FILLING → ACTIVE, and back to FILLING when reclaimed for another tile) and an
// atomic reference count held by frames in flight that sample it.
//
// Index: a lock-free open-addressing hash table (linear probing, tombstones) from tile key to
// slot. It has ONE writer, the buffer thread (insert, erase, rebuild), and any number of
// readers (the render thread, metrics). A reader never waits: it probes, then validates
// what it found against the slot's own key and status, so a stale index entry is harmless.
//
// Reclaim protocol (Dekker-style, all four operations seq_cst):
//   writer: CAS status ACTIVE→FILLING, then load refcount; if it is not 0, restore ACTIVE.
//   reader: fetch_add refcount, then load status; if it is not ACTIVE (or the key differs),
//           fetch_sub and treat the tile as absent.
// In the single total order of seq_cst operations one of the two sees the other, so a slot
// is never overwritten while a frame that has pinned it is in flight. A frame unpins its
// slots only after its fence has signalled, so "refcount 0" also means "no GPU work still
// samples it".
//
// Tombstones: erasing leaves a tombstone. When they exceed a quarter of the table the writer
// rebuilds the live entries into the spare table and publishes it. Each table has a reader
// count (a reader raises it, then re-checks that the table is still current); the writer
// reuses the retired table only when its count is 0 — checked without waiting, so a rebuild
// is simply postponed while a reader still probes the old table.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

namespace iris {

inline constexpr size_t kCacheLine = 64;

class TileMap {
public:
    enum class Status : uint32_t { Free = 0, Filling = 1, Active = 2 };

    explicit TileMap(uint32_t slotCount);
    TileMap(const TileMap&) = delete;
    TileMap& operator=(const TileMap&) = delete;

    uint32_t slotCount() const { return uint32_t(slots_.size()); }

    // --- readers (any thread) ----------------------------------------------------------
    // Pins the slot holding `key` if it is ACTIVE: returns its index with the reference count
    // raised, or -1. The caller unpins with unpin() when the GPU is done with it.
    int pin(uint64_t key, uint64_t frame);
    void unpin(int slot);
    // Lookup only (no pin): the status of `key`'s slot, Free when absent. For metrics/tests.
    Status statusOf(uint64_t key) const;
    // The upload sequence number its activation gave `slot` (see activate()). Read it only
    // for a slot this thread has pinned: the pin's acquire of ACTIVE orders the stamp.
    uint64_t uploadSeqOf(int slot) const;
    // Whether every pixel of `slot`'s tile is opaque (alpha 255), as its activation said; read
    // like uploadSeqOf. False where nobody looked.
    bool opaqueOf(int slot) const;
    // Whether `slot`'s tile has its mip levels 1..8 (activate() may leave them to come, for a
    // host-written atlas: setMipsReady()). Read for a slot this thread has pinned. Acquire: the
    // levels were written before the writer's release store, and a frame recorded after this
    // load saw true may sample them.
    bool mipsReadyOf(int slot) const;
    uint32_t countActive() const;

    // --- the writer (buffer thread only) ------------------------------------------------
    // Is the key in the index (FILLING or ACTIVE)?
    bool contains(uint64_t key) const;
    // A slot for `key`, left FILLING and indexed; -1 when none can be reclaimed. Takes FREE
    // slots first, else the least recently drawn ACTIVE slot that `keep(key)` rejects and
    // that no frame has pinned.
    template <class Keep>
    int allocate(uint64_t key, Keep&& keep);
    // Makes the slot ACTIVE, stamped with `uploadSeq`: the value of UploadCounters::tiles once
    // its upload was counted, so that metrics can tell a tile uploaded after a move from one
    // resident before it (a revisit); `opaque`: every pixel of the tile has alpha 255.
    // mipsReady false: only level 0 is in the atlas yet (a frame may draw the tile only where
    // it samples level 0 alone); the writer makes the rest and calls setMipsReady.
    void activate(int slot, uint64_t uploadSeq = 0, bool opaque = false, bool mipsReady = true);
    void setMipsReady(int slot);
    // The slot holding `key` (FILLING or ACTIVE), -1 when none: the writer's own lookup.
    int slotOf(uint64_t key) const;
    // Render thread, for tiles handed over from another queue family: makes the slot ACTIVE
    // already pinned by the frame that acquires it, so it cannot be reclaimed (and released
    // again) before that frame's acquire has executed. Unpin after the frame's fence.
    void activatePinned(int slot, uint64_t frame, uint64_t uploadSeq = 0, bool opaque = false);
    // Gives up a FILLING slot (its upload was abandoned): it becomes FREE and unindexed.
    void abandon(int slot);
    // Where the search for a FREE slot starts next: FREE slots are taken in index order from
    // here, so while the atlas fills, the slots from here on are the next to be written.
    uint32_t nextFreeHint() const { return freeHint_; }

private:
    struct alignas(kCacheLine) Slot {
        std::atomic<uint64_t> key{0};
        std::atomic<uint32_t> status{uint32_t(Status::Free)};
        std::atomic<uint32_t> refs{0};
        std::atomic<uint64_t> lastUsed{0}; // frame serial; relaxed: only an eviction hint
        // Stored relaxed before the status's release (or seq_cst) store to ACTIVE; read relaxed
        // after a pin's seq_cst load saw ACTIVE, which acquires it.
        std::atomic<uint64_t> uploadSeq{0};
        std::atomic<bool> opaque{false}; // stored and read like uploadSeq
        std::atomic<bool> mipsReady{true}; // stored like uploadSeq by activate(); setMipsReady() releases it
    };
    static_assert(sizeof(Slot) == kCacheLine, "one slot per cache line: readers and the writer touch different slots");

    struct Table {
        explicit Table(size_t capacity);
        size_t mask;
        std::unique_ptr<std::atomic<uint64_t>[]> keys; // 0 empty, kTomb erased
        std::unique_ptr<std::atomic<int32_t>[]> vals;
    };
    static constexpr uint64_t kEmpty = 0;
    static constexpr uint64_t kTomb = ~uint64_t(0);
    static size_t hash(uint64_t k) {
        k ^= k >> 33;
        k *= 0xff51afd7ed558ccdull;
        k ^= k >> 33;
        return size_t(k);
    }

    int find(const Table& t, uint64_t key) const;
    const Table* acquireTable() const;
    void releaseTable(const Table* t) const;
    void insert(uint64_t key, int slot);
    void erase(uint64_t key);
    void maybeRebuild();
    bool tryReclaim(int slot);
    int claimFree(uint64_t key);

    std::vector<Slot> slots_;
    Table tables_[2];
    // seq_cst both ways: the rebuild's store (after the spare table is filled) publishes it
    // like a release; acquireTable()'s load, fetch_add on readers_ and re-load form a Dekker
    // pair with maybeRebuild()'s load of readers_, so a table is never refilled while a
    // reader probes it.
    std::atomic<Table*> current_;
    mutable std::atomic<uint32_t> readers_[2] = {0, 0}; // readers probing tables_[i]
    // Writer-only bookkeeping.
    size_t live_ = 0;
    size_t tombs_ = 0;
    uint32_t freeHint_ = 0;
    bool reclaimAborted_ = false;

public:
    // Writer: did a reclaim back off because a reader pinned the slot at that moment? (The
    // reader may then have skipped the tile for one frame; the caller wakes the renderer.)
    bool takeReclaimAborted() {
        const bool r = reclaimAborted_;
        reclaimAborted_ = false;
        return r;
    }
};

template <class Keep>
int TileMap::allocate(uint64_t key, Keep&& keep) {
    if (int s = claimFree(key); s >= 0) return s;
    // Least recently drawn first among reclaimable candidates.
    int best = -1;
    uint64_t oldest = UINT64_MAX;
    std::vector<int> tried;
    for (int attempt = 0; attempt < 4; ++attempt) {
        best = -1;
        oldest = UINT64_MAX;
        for (size_t i = 0; i < slots_.size(); ++i) {
            const Slot& s = slots_[i];
            if (s.status.load(std::memory_order_relaxed) != uint32_t(Status::Active)) continue;
            if (s.refs.load(std::memory_order_relaxed) != 0) continue; // pinned: not a candidate now
            const uint64_t k = s.key.load(std::memory_order_relaxed);
            if (keep(k)) continue;
            const uint64_t used = s.lastUsed.load(std::memory_order_relaxed);
            if (used < oldest) {
                oldest = used;
                best = int(i);
            }
        }
        if (best < 0) return -1;
        if (tryReclaim(best)) {
            Slot& s = slots_[size_t(best)];
            erase(s.key.load(std::memory_order_relaxed));
            s.key.store(key, std::memory_order_release); // pairs with pin()'s acquire load
            insert(key, best);
            return best;
        }
    }
    return -1;
}

} // namespace iris
