// Fresh memory made resident in bulk, ahead of the write that would otherwise fault it in a page
// at a time.
//
// The first write to a page of fresh anonymous memory traps into the kernel, which zeroes a
// page and maps it: 64 traps for a 256 KiB tile. In a virtual machine every trap also exits to
// the hypervisor, and measured on the development machine (a Firecracker VM, kernel 6.18) a
// tile's worth of first writes costs 130-420 µs against 10 µs for rewriting memory already
// resident: more than decoding the tile. madvise(MADV_POPULATE_WRITE) (Linux 5.14) faults the
// whole range in one call, about 75 µs a tile there (docs/BENCHMARKS.md, "Loading frames by
// segments, and memory ahead of need"). The engine calls it for the host-written atlas's
// slots, from the buffer thread while it is idle (BufferThread::prefaultAtlas). Not for the RAM
// cache's buffers: each is a mapping of its own, and populating them from many loaders at once
// contended in the kernel on a 16-core machine where plain faults did not; idle loaders zero a
// reserve of them instead (TileCache::replenish).
#pragma once

#include <cstddef>

namespace iris {

// Makes the whole pages inside [p, p + bytes) resident and writable without changing their
// contents. Best effort: where the kernel lacks MADV_POPULATE_WRITE (before 5.14) or refuses
// the range, it does nothing and the pages fault in when written, as before.
void prefaultForWrite(void* p, size_t bytes);

} // namespace iris
