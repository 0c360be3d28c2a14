/// The keyframe database saved with a map (output/keyframe_section.hpp): arbitrary bytes parsed
/// as Reconstruction::load_map parses the section of a version 5 or 6 map file, then used as
/// the relocaliser uses it (a query with a code of its size).

#include "core/platform.hpp"
#include "localise/keyframe_database.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const kfx::KeyframeDatabase db = kfx::KeyframeDatabase::parse(data, size, "fuzz", 0);
    if (db.size() > db.capacity()) abort();
    if (static_cast<int>(db.tests().size()) !=
        db.fern_count() * kfx::KeyframeDatabase::kTestsPerFern) {
      abort();
    }
    if (db.width_px() <= 0 || db.height_px() <= 0) abort();
    if (static_cast<uint64_t>(db.width_px()) * db.height_px() <= (1u << 20)) {
      const kfx::HostImage<uint16_t> image(db.width_px(), db.height_px(), 1000);
      const auto nearest = db.nearest(db.encode(image.view()), 3);
      for (const auto& m : nearest) {
        if (m.keyframe < 0 || m.keyframe >= db.size()) abort();
      }
    }
    if (db.serialise().size() != size) abort();
  } catch (const kfx::Error&) {
  }
  return 0;
}
