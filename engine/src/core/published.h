// Published<T>: an immutable object that writers replace whole and any thread reads, each reader
// getting one complete object that stays alive while it holds it (the published snapshot, the
// render thread's last frame and overlay layout, the frame callback).
//
// Why not std::atomic<std::shared_ptr<const T>>: libstdc++ 12 (Debian 12's) implements it with a
// lock bit in the control-block pointer, and its load() releases that bit with a *relaxed* store,
// so a load's read of the object pointer and a later store's write of it are not ordered by the
// C++ memory model (ThreadSanitizer reports the race; newer libstdc++ releases with `release`).
// This is the same design with the orders right: a spin lock held for one shared_ptr copy or
// swap (a pointer and a reference-count increment, a few nanoseconds), taken with acquire and
// released with release on both sides. No reader or writer ever sleeps on it, waits for I/O or
// the GPU under it, or runs foreign code under it; the object a store replaces is released after
// the lock is dropped, so a destructor never runs inside it.
#pragma once

#include <atomic>
#include <memory>
#include <thread>

namespace iris {

template <class T>
class Published {
public:
    Published() = default;
    explicit Published(std::shared_ptr<const T> initial) : ptr_(std::move(initial)) {}
    Published(const Published&) = delete;
    Published& operator=(const Published&) = delete;

    // The current object (null when none was published), kept alive by the returned pointer.
    std::shared_ptr<const T> load() const {
        lock();
        std::shared_ptr<const T> p = ptr_;
        unlock();
        return p;
    }
    // Publishes `next` (may be null); readers that loaded the previous object keep it.
    void store(std::shared_ptr<const T> next) {
        lock();
        ptr_.swap(next);
        unlock();
        // `next` now holds the previous object, released here, outside the lock.
    }

private:
    void lock() const {
        // exchange(acquire) pairs with unlock()'s store(release): the holder before us has
        // finished its copy or swap of ptr_ before we touch it.
        for (unsigned spins = 0; busy_.exchange(true, std::memory_order_acquire);) {
            while (busy_.load(std::memory_order_relaxed)) { // relaxed: only a hint to retry
                if (++spins % 64 == 0) std::this_thread::yield(); // the holder was preempted
            }
        }
    }
    void unlock() const { busy_.store(false, std::memory_order_release); }

    mutable std::atomic<bool> busy_{false};
    std::shared_ptr<const T> ptr_;
};

} // namespace iris
