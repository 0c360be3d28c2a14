/// kfx_api_trajectory: a sequence through the public C++ API alone, as `kfx run` feeds it (one
/// frame in flight), its trajectory written as `kfx run`'s trajectory.txt. For the test that the
/// CLI, the C++ API and Python give byte-identical trajectories (tests/python).
///
/// Usage: kfx_api_trajectory INPUT OUT.txt [--frames N] [--backend B] [KEY=VALUE ...]

#include <cstdio>
#include <cstdlib>
#include <kfx/kfx.hpp>
#include <string>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: kfx_api_trajectory INPUT OUT.txt [--frames N] [--backend B] "
                 "[KEY=VALUE ...]\n");
    return 2;
  }
  const std::string input = argv[1], out = argv[2];
  try {
    kfx::Settings settings;
    int max_frames = 0;  // 0: all
    for (int i = 3; i < argc; ++i) {
      const std::string arg = argv[i];
      if ((arg == "--frames" || arg == "--backend") && i + 1 < argc) {
        const std::string value = argv[++i];
        if (arg == "--frames") {
          max_frames = std::atoi(value.c_str());
        } else {
          settings.backend(value);
        }
        continue;
      }
      const size_t eq = arg.find('=');
      if (eq == std::string::npos) {
        std::fprintf(stderr, "kfx_api_trajectory: '%s' is not KEY=VALUE\n", arg.c_str());
        return 2;
      }
      settings.set(arg.substr(0, eq), arg.substr(eq + 1));
    }
    kfx::Sequence sequence(input);
    kfx::Reconstruction reconstruction(settings, sequence);
    kfx::SequenceFrame frame;
    int submitted = 0;
    while ((max_frames == 0 || submitted < max_frames) &&
           sequence.next(frame) == kfx::ReadStatus::kOk) {
      reconstruction.submit(frame);
      ++submitted;
      if (reconstruction.frames_in_flight() > 1) reconstruction.collect();
    }
    while (reconstruction.frames_in_flight() > 0) reconstruction.collect();
    reconstruction.save_trajectory(out);
    std::printf("kfx_api_trajectory: %d frames of %s to %s\n", submitted, input.c_str(),
                out.c_str());
    return 0;
  } catch (const kfx::Error& e) {
    std::fprintf(stderr, "kfx_api_trajectory: %s\n", e.what());
    return 1;
  }
}
