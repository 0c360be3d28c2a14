/// The block hash (map/block_hash.hpp) against a std::map model: the input is a table size and
/// a sequence of inserts and finds over a small key space (so collisions, full tables and
/// present keys are frequent). Any disagreement aborts.

#include <cstdlib>
#include <map>
#include <vector>

#include "map/block_hash.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint32_t slots = 1u << (data[0] % 9);  // 1 … 256 slots
  std::vector<uint64_t> keys(slots, kfx::kEmptyBlockKey);
  std::vector<int32_t> values(slots, -1);
  const kfx::BlockHashView hash{keys.data(), values.data(), slots - 1};
  std::map<uint64_t, int32_t> model;
  int32_t next_value = 0;
  for (size_t i = 1; i + 2 < size; i += 3) {
    // Coordinates from a few bits each, negatives included: a dense, colliding key space.
    const int x = static_cast<int8_t>(data[i + 1]) >> 4, y = static_cast<int8_t>(data[i + 1]) % 8,
              z = static_cast<int8_t>(data[i + 2]) % 4;
    const uint64_t key = kfx::pack_block_key(x, y, z);
    if (data[i] & 1) {
      const kfx::BlockInsert outcome = hash.insert(key, next_value);
      const bool present = model.count(key) != 0;
      const bool full = model.size() == slots;
      const kfx::BlockInsert expected = present ? kfx::BlockInsert::kPresent
                                        : full  ? kfx::BlockInsert::kFull
                                                : kfx::BlockInsert::kInserted;
      if (outcome != expected) abort();
      if (outcome == kfx::BlockInsert::kInserted) model[key] = next_value++;
    } else {
      const auto it = model.find(key);
      if (hash.find(key) != (it == model.end() ? -1 : it->second)) abort();
    }
  }
  for (const auto& [key, value] : model) {
    if (hash.find(key) != value) abort();
  }
  return 0;
}
