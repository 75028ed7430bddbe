// What fuzz_geojson and fuzz_asap_xml share: the promises every annotation reader keeps.
//
//   - a failure names what is wrong (a non-empty message starting with the format's name);
//   - what it read, written back in the same format, reads again, and writing that gives the
//     same text (the writer and reader agree: no loss after the first read's normalisation);
//   - the store takes the document whole or refuses it whole (only for ids used twice), and
//     its snapshot holds every object, finds each by id, returns them all for its bounds;
//   - fills of the first polygons triangulate (GEOS, also for self-intersecting rings) or give
//     an error with a message; hit-testing at each object's centre does not crash.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "fuzz_signals.h"
#include "iris/annotations.h"

namespace fuzz_ann {

[[noreturn]] inline void broken(const char* file, int line, const char* what) {
    std::fprintf(stderr, "%s:%d: broken promise: %s\n", file, line, what);
    std::abort();
}
#define PROMISE(cond)                                                                                                  \
    do {                                                                                                               \
        if (!(cond)) ::fuzz_ann::broken(__FILE__, __LINE__, #cond);                                                    \
    } while (0)

template <class Read, class Write>
void check(std::string_view text, const char* formatName, Read read, Write write) {
    auto doc = read(text);
    if (!doc.ok()) {
        const std::string& m = doc.error().message();
        PROMISE(m.rfind(formatName, 0) == 0);
        return;
    }
    const std::string once = write(*doc);
    auto again = read(once);
    if (!again.ok()) std::fprintf(stderr, "re-read: %s\n", again.error().message().c_str());
    PROMISE(again.ok());
    const std::string twice = write(*again);
    if (twice != once) std::fprintf(stderr, "--- once\n%s\n--- twice\n%s\n", once.c_str(), twice.c_str());
    PROMISE(twice == once);

    iris::AnnotationStore store;
    const iris::Result r = store.replaceAll(doc->objects, doc->classes);
    if (!r.ok()) {
        PROMISE(r.message().find("is used twice") != std::string::npos);
        return;
    }
    auto s = store.snapshot();
    PROMISE(s->size() == doc->objects.size());
    size_t seen = 0, filled = 0;
    s->forEach([&](const iris::StoredAnnotation& a) {
        ++seen;
        PROMISE(s->find(a.object.id) == &a);
        const iris::Box2& b = a.bounds;
        (void)s->hitTest({(b.minX + b.maxX) / 2, (b.minY + b.maxY) / 2}, 1.0);
        if (a.object.kind == iris::AnnotationKind::Point || a.object.kind == iris::AnnotationKind::Polyline) return;
        if (filled++ >= 8) return;
        size_t vertices = 0;
        for (const auto& p : a.object.polygons) {
            vertices += p.outer.size();
            for (const auto& h : p.holes) vertices += h.size();
        }
        if (vertices > 20000) return; // GEOS's time, not a bug
        auto t = s->fillTriangles(a, 1.0);
        if (t.ok()) PROMISE((*t)->vertices.size() % 3 == 0);
        else PROMISE(!t.error().message().empty());
    });
    PROMISE(seen == s->size());
    if (seen) PROMISE(s->query(s->bounds()).size() == seen);
}

} // namespace fuzz_ann
