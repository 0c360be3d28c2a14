/// The keyframe database saved with a map (output/keyframe_section.hpp): arbitrary bytes parsed
/// as Reconstruction::load_map parses the section of a version 5 or 6 map file (either section
/// version: with the keyframes' small images or without), then used as the relocaliser uses it
/// (a query with a code of its size, a keyframe's image).

#include "core/platform.hpp"
#include "localise/keyframe_database.hpp"

namespace {

/// Parses the bytes as a section of either version and uses what came back.
void parse_and_use(const uint8_t* data, size_t size, bool with_images) {
  try {
    const kfx::KeyframeDatabase db =
        kfx::KeyframeDatabase::parse(data, size, "fuzz", 0, with_images);
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
        const kfx::ImageView<const uint16_t> small = db.image(m.keyframe);
        if ((small.data != nullptr) != with_images) abort();
        if (small.data != nullptr) {
          // Its last pixel read, so that a short image is caught by the sanitisers.
          const volatile uint16_t last = small(small.width - 1, small.height - 1);
          (void)last;
        }
      }
    }
    if (db.serialise().size() != size) abort();
  } catch (const kfx::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (const bool with_images : {false, true}) parse_and_use(data, size, with_images);
  return 0;
}
