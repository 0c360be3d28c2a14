#include "localise/keyframe_database.hpp"

#include <algorithm>
#include <cstring>

#include "core/platform.hpp"
#include "core/se3.hpp"

namespace kfx {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the keyframe section is copied as it lies in memory (little-endian)");

/// SplitMix64 (Steele et al. 2014): a generator whose sequence is the same in every standard
/// library, unlike std::uniform_int_distribution's mapping.
uint64_t split_mix(uint64_t& state) {
  uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

/// A number in [0, n) from the generator (the modulo's bias is far below what matters here).
int draw(uint64_t& state, int n) {
  return static_cast<int>(split_mix(state) % static_cast<uint64_t>(n));
}

/// Bytes of one keyframe's record in the section: frame number and pose.
constexpr size_t kKeyframeRecordBytes = 4 + 64;
/// Bytes of the section's header: width, height, ferns, tests per fern, keyframes.
constexpr size_t kSectionHeaderBytes = 5 * 4;
/// Largest small image and fern count a section may declare (far above any setting).
constexpr int kMaxSmallSidePx = 4096;
constexpr int kMaxFerns = 1 << 16;
constexpr int kMaxKeyframes = 1 << 24;

/// Bytes one keyframe takes in memory at most: its code, its record and its small image.
uint64_t keyframe_bytes(int ferns, int width_px, int height_px) {
  return static_cast<uint64_t>(ferns) + sizeof(Keyframe) +
         static_cast<uint64_t>(width_px) * height_px * sizeof(uint16_t);
}

}  // namespace

KeyframeDatabase::KeyframeDatabase(int width_px, int height_px, int fern_count, int capacity)
    : width_px_(width_px), height_px_(height_px), fern_count_(fern_count), capacity_(capacity) {
  KFX_CHECK(width_px > 0 && height_px > 0 && fern_count > 0 && capacity >= 0,
            "keyframe database of " << fern_count << " ferns on " << width_px << "x" << height_px
                                    << " pixels, capacity " << capacity);
  uint64_t state = kSeed;
  tests_.resize(static_cast<size_t>(fern_count) * kTestsPerFern);
  for (FernTest& t : tests_) {
    t.x_px = static_cast<uint16_t>(draw(state, width_px));
    t.y_px = static_cast<uint16_t>(draw(state, height_px));
    t.threshold_mm =
        static_cast<uint16_t>(kMinThresholdMm + draw(state, kMaxThresholdMm - kMinThresholdMm + 1));
  }
}

std::vector<uint8_t> KeyframeDatabase::encode(ImageView<const uint16_t> small_mm) const {
  KFX_CHECK(small_mm.width == width_px_ && small_mm.height == height_px_,
            "a " << small_mm.width << "x" << small_mm.height << " small depth image for ferns on "
                 << width_px_ << "x" << height_px_);
  std::vector<uint8_t> code(static_cast<size_t>(fern_count_));
  for (int f = 0; f < fern_count_; ++f) {
    uint8_t bits = 0;
    for (int i = 0; i < kTestsPerFern; ++i) {
      const FernTest& t = tests_[static_cast<size_t>(f) * kTestsPerFern + i];
      if (small_mm(t.x_px, t.y_px) > t.threshold_mm) bits |= static_cast<uint8_t>(1u << i);
    }
    code[static_cast<size_t>(f)] = bits;
  }
  return code;
}

std::vector<KeyframeMatch> KeyframeDatabase::nearest(const std::vector<uint8_t>& code,
                                                     int k) const {
  KFX_CHECK(static_cast<int>(code.size()) == fern_count_,
            "a code of " << code.size() << " ferns for a database of " << fern_count_);
  std::vector<KeyframeMatch> all;
  all.reserve(keyframes_.size());
  for (int i = 0; i < size(); ++i) {
    const uint8_t* stored = codes_.data() + static_cast<size_t>(i) * fern_count_;
    int differ = 0;
    for (int f = 0; f < fern_count_; ++f) differ += stored[f] != code[static_cast<size_t>(f)];
    all.push_back(KeyframeMatch{i, static_cast<float>(differ) / fern_count_});
  }
  const size_t keep = std::min(all.size(), static_cast<size_t>(std::max(k, 0)));
  std::partial_sort(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(keep), all.end(),
                    [](const KeyframeMatch& a, const KeyframeMatch& b) {
                      return a.dissimilarity < b.dissimilarity ||
                             (a.dissimilarity == b.dissimilarity && a.keyframe < b.keyframe);
                    });
  all.resize(keep);
  return all;
}

bool KeyframeDatabase::add(const std::vector<uint8_t>& code, const Keyframe& keyframe,
                           ImageView<const uint16_t> small_mm) {
  KFX_CHECK(static_cast<int>(code.size()) == fern_count_,
            "a code of " << code.size() << " ferns for a database of " << fern_count_);
  const bool with_image = small_mm.data != nullptr;
  KFX_CHECK(!with_image || (small_mm.width == width_px_ && small_mm.height == height_px_),
            "a " << small_mm.width << "x" << small_mm.height << " keyframe image for a database of "
                 << width_px_ << "x" << height_px_);
  if (full()) return false;
  codes_.insert(codes_.end(), code.begin(), code.end());
  keyframes_.push_back(keyframe);
  images_.push_back(with_image ? copy_of(small_mm) : HostImage<uint16_t>());
  return true;
}

ImageView<const uint16_t> KeyframeDatabase::image(int i) const {
  if (i < 0 || i >= size() || images_[static_cast<size_t>(i)].empty()) return {};
  return images_[static_cast<size_t>(i)].view();
}

bool KeyframeDatabase::has_images() const {
  return std::none_of(images_.begin(), images_.end(),
                      [](const HostImage<uint16_t>& image) { return image.empty(); });
}

void KeyframeDatabase::clear() {
  codes_.clear();
  keyframes_.clear();
  images_.clear();
}

uint64_t KeyframeDatabase::memory_bytes() const {
  uint64_t images = 0;
  for (const HostImage<uint16_t>& image : images_)
    images += image.pixels().size() * sizeof(uint16_t);
  return tests_.size() * sizeof(FernTest) +
         static_cast<uint64_t>(size()) * (static_cast<uint64_t>(fern_count_) + sizeof(Keyframe)) +
         images;
}

uint64_t KeyframeDatabase::capacity_bytes() const {
  return tests_.size() * sizeof(FernTest) +
         static_cast<uint64_t>(capacity_) * keyframe_bytes(fern_count_, width_px_, height_px_);
}

std::vector<uint8_t> KeyframeDatabase::serialise() const {
  std::vector<uint8_t> out;
  const int32_t header[5] = {width_px_, height_px_, fern_count_, kTestsPerFern, size()};
  const auto append = [&out](const void* data, size_t bytes) {
    const auto* p = static_cast<const uint8_t*>(data);
    out.insert(out.end(), p, p + bytes);
  };
  append(header, sizeof(header));
  for (const FernTest& t : tests_) {
    const uint16_t fields[3] = {t.x_px, t.y_px, t.threshold_mm};
    append(fields, sizeof(fields));
  }
  append(codes_.data(), codes_.size());
  for (const Keyframe& k : keyframes_) {
    const int32_t frame = k.frame;
    append(&frame, 4);
    append(k.T_world_cam.m, 64);
  }
  if (has_images()) {
    for (const HostImage<uint16_t>& image : images_) {
      append(image.data(), image.pixels().size() * sizeof(uint16_t));
    }
  }
  return out;
}

KeyframeDatabase KeyframeDatabase::parse(const uint8_t* bytes, size_t size, const std::string& file,
                                         int capacity, bool with_images) {
  const std::string where = file + ": the keyframe database ";
  KFX_CHECK(size >= kSectionHeaderBytes,
            where << "is truncated (" << size << " bytes, shorter than its header)");
  int32_t header[5];
  std::memcpy(header, bytes, sizeof(header));
  const int width = header[0], height = header[1], ferns = header[2], tests = header[3],
            count = header[4];
  KFX_CHECK(width > 0 && height > 0 && width <= kMaxSmallSidePx && height <= kMaxSmallSidePx,
            where << "declares a " << width << "x" << height << " image (a corrupt file)");
  KFX_CHECK(ferns > 0 && ferns <= kMaxFerns,
            where << "declares " << ferns << " ferns (a corrupt file)");
  KFX_CHECK(tests == kTestsPerFern,
            where << "has " << tests << " tests per fern, this kfx uses " << kTestsPerFern);
  KFX_CHECK(count >= 0 && count <= kMaxKeyframes,
            where << "declares " << count << " keyframes (a corrupt file)");
  const size_t image_bytes =
      with_images ? static_cast<size_t>(width) * height * sizeof(uint16_t) : 0;
  const size_t want = kSectionHeaderBytes +
                      static_cast<size_t>(ferns) * kTestsPerFern * 3 * sizeof(uint16_t) +
                      static_cast<size_t>(count) *
                          (static_cast<size_t>(ferns) + kKeyframeRecordBytes + image_bytes);
  KFX_CHECK(size == want, where << "has " << size << " bytes; " << count << " keyframes of "
                                << ferns << " ferns"
                                << (with_images ? " with their small images" : "") << " take "
                                << want << " (truncated or corrupt)");
  KeyframeDatabase db;
  db.width_px_ = width;
  db.height_px_ = height;
  db.fern_count_ = ferns;
  db.capacity_ = std::max(capacity, count);
  const uint8_t* p = bytes + kSectionHeaderBytes;
  db.tests_.resize(static_cast<size_t>(ferns) * kTestsPerFern);
  for (FernTest& t : db.tests_) {
    uint16_t fields[3];
    std::memcpy(fields, p, sizeof(fields));
    p += sizeof(fields);
    KFX_CHECK(fields[0] < width && fields[1] < height,
              where << "has a fern test at pixel (" << fields[0] << ", " << fields[1]
                    << ") outside its " << width << "x" << height << " image (a corrupt file)");
    t = FernTest{fields[0], fields[1], fields[2]};
  }
  db.codes_.assign(p, p + static_cast<size_t>(count) * ferns);
  p += static_cast<size_t>(count) * ferns;
  for (uint8_t c : db.codes_) {
    KFX_CHECK(c < (1u << kTestsPerFern), where << "has a fern code " << int(c) << " wider than "
                                               << kTestsPerFern << " bits (a corrupt file)");
  }
  db.keyframes_.resize(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i) {
    Keyframe& k = db.keyframes_[static_cast<size_t>(i)];
    int32_t frame = 0;
    std::memcpy(&frame, p, 4);
    std::memcpy(k.T_world_cam.m, p + 4, 64);
    p += kKeyframeRecordBytes;
    k.frame = frame;
    const std::string problem = rigid_transform_problem(k.T_world_cam);
    KFX_CHECK(problem.empty(), where << "keyframe " << i << "'s pose " << problem);
  }
  // Any depth is a depth (0 a hole): the images need no check beyond their size.
  db.images_.resize(static_cast<size_t>(count));
  if (with_images) {
    const size_t pixels = static_cast<size_t>(width) * height;
    for (HostImage<uint16_t>& image : db.images_) {
      image = HostImage<uint16_t>(width, height);
      std::memcpy(image.data(), p, pixels * sizeof(uint16_t));
      p += pixels * sizeof(uint16_t);
    }
  }
  return db;
}

}  // namespace kfx
