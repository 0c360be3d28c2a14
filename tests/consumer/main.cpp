// Reconstructs a short synthetic sequence through the installed public API and checks that
// tracking held and a mesh came out; prints one line. Exit status 0 on success.
#include <cstdio>
#include <kfx/kfx.hpp>

int main(int argc, char** argv) {
  const char* input = argc > 1 ? argv[1] : "synthetic:frames=12,width=160,height=120";
  try {
    kfx::Sequence sequence(input);
    kfx::Settings settings;
    settings.backend("cpu").set("volume_resolution", "64");
    kfx::Reconstruction reconstruction(settings, sequence);
    kfx::SequenceFrame frame;
    int tracked = 0;
    while (sequence.next(frame) == kfx::ReadStatus::kOk) {
      tracked += reconstruction.process(frame).tracked ? 1 : 0;
    }
    const kfx::TriangleMesh mesh = reconstruction.mesh();
    std::printf("kfx %s: %zu frames, %d tracked, mesh of %zu triangles\n", kfx::version(),
                reconstruction.trajectory().size(), tracked, mesh.triangle_count());
    // Frames 0-3 only integrate; every later frame of the noiseless room must track.
    const bool ok =
        reconstruction.trajectory().size() == 12 && tracked == 8 && mesh.triangle_count() > 0;
    // A bad setting is an exception naming it.
    try {
      settings.set("volume_resolutoin", "64");
      return 1;
    } catch (const kfx::Error& e) {
      std::printf("bad setting: %s\n", e.what());
    }
    return ok ? 0 : 1;
  } catch (const kfx::Error& e) {
    std::fprintf(stderr, "kfx_consumer: %s\n", e.what());
    return 1;
  }
}
