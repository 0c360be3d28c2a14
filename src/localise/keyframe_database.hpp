#pragma once
/// The keyframe database: camera poses of frames tracked well, each filed under a compact code
/// of its small depth image (kernels/small_depth.hpp), so that a lost camera can find the
/// keyframes whose views look most like its own and try their poses. The code is a set of
/// random ferns (Glocker et al., "Real-time RGB-D camera relocalization via randomized ferns
/// for keyframe encoding", TVCG 2015; InfiniTAM v3's relocaliser): each fern is a few tests
/// "is the depth at pixel p beyond d?", its code the tests' bits; two views differ by the share
/// of ferns whose codes differ. Each keyframe also keeps its small image, so that a lost view
/// can be aligned to it (localise/small_depth_alignment.hpp). One floor above the frame loop:
/// host code over the small image made on the host from each frame's input depth
/// (localise/input_small_depth.hpp).

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.hpp"
#include "core/math.hpp"

namespace kfx {

/// One fern test: bit = (depth at (x, y) > threshold); a hole (0) reads as near, bit 0.
struct FernTest {
  uint16_t x_px = 0;
  uint16_t y_px = 0;
  uint16_t threshold_mm = 0;
};

/// A keyframe: the pose of a well-tracked frame and its number.
struct Keyframe {
  Mat4f T_world_cam;
  int frame = 0;  ///< the pipeline's frame number
};

/// A nearest keyframe and how much its code differs from the query's (share of ferns, 0–1).
struct KeyframeMatch {
  int keyframe = -1;
  float dissimilarity = 1.0f;
};

/// Random ferns over a small depth image, and the keyframes filed under their codes.
class KeyframeDatabase {
 public:
  /// Tests per fern (a code of 4 bits, 16 values; InfiniTAM's).
  static constexpr int kTestsPerFern = 4;
  /// Thresholds are drawn uniformly in this depth range, mm: where indoor depth cameras see.
  static constexpr int kMinThresholdMm = 300;
  static constexpr int kMaxThresholdMm = 4000;
  /// The fixed seed: the same image gets the same code in every run and on every machine.
  static constexpr uint64_t kSeed = 0x6b66786665726e73ull;

  KeyframeDatabase() = default;
  /// `fern_count` ferns over a width × height small image (fixed seed); room for `capacity`
  /// keyframes (the database stops growing there).
  KeyframeDatabase(int width_px, int height_px, int fern_count, int capacity);

  /// The code of a small depth image of this database's size: one byte per fern.
  std::vector<uint8_t> encode(ImageView<const uint16_t> small_mm) const;
  /// The `k` keyframes whose codes differ least from `code`, nearest first (ties: older first).
  std::vector<KeyframeMatch> nearest(const std::vector<uint8_t>& code, int k) const;
  /// Files a keyframe under `code`, with the small depth image the code was made from (kept so
  /// that a lost view can be aligned to the keyframe: localise/small_depth_alignment.hpp; an
  /// empty view: none, as in maps saved before images were kept); false (nothing added) when
  /// full.
  bool add(const std::vector<uint8_t>& code, const Keyframe& keyframe,
           ImageView<const uint16_t> small_mm = {});
  /// Room for `capacity` keyframes (never fewer than it holds).
  void set_capacity(int capacity) { capacity_ = capacity > size() ? capacity : size(); }
  /// Forgets every keyframe (the ferns stay).
  void clear();

  int width_px() const { return width_px_; }
  int height_px() const { return height_px_; }
  int fern_count() const { return fern_count_; }
  int capacity() const { return capacity_; }
  int size() const { return static_cast<int>(keyframes_.size()); }
  bool empty() const { return keyframes_.empty(); }
  bool full() const { return size() >= capacity_; }
  const Keyframe& keyframe(int i) const { return keyframes_[static_cast<size_t>(i)]; }
  const std::vector<FernTest>& tests() const { return tests_; }
  /// Keyframe `i`'s small depth image; an empty view (null data) when it has none.
  ImageView<const uint16_t> image(int i) const;
  /// Whether every keyframe has its small image (so the section saves them).
  bool has_images() const;
  /// Bytes the database takes now: the tests, the codes, the keyframes and their images.
  uint64_t memory_bytes() const;
  /// Bytes it takes when full.
  uint64_t capacity_bytes() const;

  /// The database (ferns, codes, poses, and the small images when has_images()) as bytes,
  /// little-endian, as the map files embed it (output/keyframe_section.hpp describes the
  /// layout).
  std::vector<uint8_t> serialise() const;
  /// Parses what serialise() made, `with_images` as has_images() was; throws kfx::Error naming
  /// `file` on a truncated or corrupt section. `capacity`: room for keyframes in the result
  /// (raised to the stored count).
  static KeyframeDatabase parse(const uint8_t* bytes, size_t size, const std::string& file,
                                int capacity, bool with_images = false);

 private:
  int width_px_ = 0;
  int height_px_ = 0;
  int fern_count_ = 0;
  int capacity_ = 0;
  std::vector<FernTest> tests_;  ///< fern_count × kTestsPerFern
  std::vector<uint8_t> codes_;   ///< size() × fern_count, keyframe-major
  std::vector<Keyframe> keyframes_;
  /// Per keyframe its small image, width × height mm row by row; empty: none.
  std::vector<HostImage<uint16_t>> images_;
};

}  // namespace kfx
