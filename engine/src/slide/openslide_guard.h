// Checks made before OpenSlide 3.4.1 (Debian 12's) sees a file. Some hostile files kill the
// process inside it, while it opens them or reads a tile: a division by zero, GLib's abort on
// an allocation a few bytes of the file ask for, a NULL or out-of-bounds read. Those found
// (tests/fuzz, and a read of its TIFF vendors' readers; tests/fuzz/README.md lists them) are
// refused here, with libtiff and pugixml, before OpenSlide is called. A file this passes may
// still be one OpenSlide refuses itself, with an error.
//
// Threading: any thread (libtiff's error handlers are silenced while the file is opened).
#pragma once

#include <string>

#include "iris/types.h"

namespace iris {

// Ok, or CorruptData / UnsupportedFormat naming `name` (the file as the host knows it; `path`
// may be a /proc/self/fd name) and why. Not a TIFF: ok (OpenSlide decides). When ok, *vendor
// is what openslide_detect_vendor names for the file (a static string; null for none), which
// the check asks once the file's layout has passed.
Result checkFileForOpenSlide(const std::string& path, const std::string& name, const char** vendor);

} // namespace iris
