#pragma once
/// The maps a backend holds and the one its stages act on. A backend starts with one map (map 0,
/// made from its BackendSetup); create_map adds another of the same kind and size, and select
/// makes a map the one every stage (integrate, raycast, render, mesh, read and upload) reaches
/// through current(). What is not a map (the frame's images, the pyramid, the raycast reference
/// view, the camera's tracking state) stays the backend's, shared by its maps.
///
/// The maps live in a deque: adding one never moves the others, so a reference to a map (and
/// anything that captured its memory) stays valid while the set lives.

#include <deque>
#include <utility>

#include "core/platform.hpp"

namespace kfx {

template <class Map>
class MapSet {
 public:
  /// The set of one map, `first` (map 0), selected.
  explicit MapSet(Map first) { maps_.push_back(std::move(first)); }

  /// Adds `map` (not selected) and returns its handle: the index of the new map.
  int add(Map map) {
    maps_.push_back(std::move(map));
    return count() - 1;
  }
  /// Makes map `handle` the current one; throws kfx::Error for a handle the set lacks.
  void select(int handle) {
    check(handle, "select_map()");
    selected_ = handle;
  }
  /// The map every stage acts on.
  Map& current() { return maps_[static_cast<size_t>(selected_)]; }
  int selected() const { return selected_; }
  int count() const { return static_cast<int>(maps_.size()); }

 private:
  void check(int handle, const char* what) const {
    KFX_CHECK(handle >= 0 && handle < count(), what << ": map " << handle << " does not exist: the "
                                                    << "backend holds " << count() << " map"
                                                    << (count() == 1 ? "" : "s") << " (0 to "
                                                    << count() - 1 << ")");
  }

  std::deque<Map> maps_;
  int selected_ = 0;
};

}  // namespace kfx
