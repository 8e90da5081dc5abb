// mm4mm render: top-down pictures of a session, or of an atlas (merged map and fused magnetic map).

#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/render/magnetic_map_render.hpp"
#include "mm4mm/render/session_render.hpp"

namespace mm4mm::cli {
namespace {

namespace fs = std::filesystem;

struct RenderOptions {
  std::string input;
  std::string out;
  double pixels_per_metre = 10.0;
  bool scale_given = false;  // else each picture keeps its own default scale
};

// X.png -> X_magnetic.png, beside it.
fs::path magneticPicturePath(const fs::path& out) {
  return out.parent_path() / (out.stem().string() + "_magnetic" + out.extension().string());
}

// The directory's own name, also for "dir/" and ".".
std::string directoryName(const fs::path& dir) {
  const fs::path name = fs::weakly_canonical(dir).filename();
  return name.empty() ? dir.string() : name.string();
}

void renderSession(const fs::path& dir, const SessionRenderOptions& render, const fs::path& out) {
  const Session session = readSession(dir);
  renderSessionPng(session, render, out);
  std::printf("%s\n", out.c_str());
}

// Reads everything first, so that an atlas with a broken part gets no picture at all.
void renderAtlas(const fs::path& dir, const RenderOptions& options,
                 const SessionRenderOptions& render, const fs::path& out) {
  spdlog::info("reading atlas {} and its sessions ...", dir.string());
  const Atlas atlas = loadAtlas(dir);
  const MagneticMap magnetic = readMagneticMapPcd(dir / "magnetic_map.pcd");
  std::vector<const Session*> sessions;
  std::size_t connected = 0;
  for (std::size_t s = 0; s < atlas.sessions.size(); ++s) {
    sessions.push_back(&atlas.sessions[s]);
    connected += atlas.connected[s] ? 1 : 0;
  }
  const std::string name = "atlas " + directoryName(dir);
  spdlog::info("drawing the merged map of {} sessions ({} connected) ...", sessions.size(),
               connected);
  renderAtlasPng(sessions, atlas.T_atlas_keyframe, atlas.connected, render,
                 name + ": " + std::to_string(sessions.size()) + " sessions, " +
                     std::to_string(connected) + " connected",
                 out);
  std::printf("%s\n", out.c_str());

  const fs::path magnetic_out = magneticPicturePath(out);
  if (magnetic.coveredCells() == 0) {
    spdlog::warn("{}: the fused magnetic map covers no cell; no {}",
                 (dir / "magnetic_map.pcd").string(), magnetic_out.string());
    return;
  }
  MagneticMapRenderOptions magnetic_render;
  magnetic_render.title = name + " fused magnetic map";
  if (options.scale_given) magnetic_render.pixels_per_metre = options.pixels_per_metre;
  renderMagneticMapPng(magnetic, magnetic_render, magnetic_out);
  std::printf("%s\n", magnetic_out.c_str());
}

void runRender(const RenderOptions& options) {
  SessionRenderOptions render;
  if (options.scale_given) render.pixels_per_metre = options.pixels_per_metre;
  std::string problem;
  if (!render.IsValid(&problem)) throw std::invalid_argument("render options: " + problem);
  const fs::path input(options.input);
  const fs::path out(options.out);
  if (fs::exists(input / "atlas.yaml")) {
    renderAtlas(input, options, render, out);
  } else if (fs::exists(input / "session.yaml")) {
    renderSession(input, render, out);
  } else {
    throw InputError(options.input, 0,
                     "neither an atlas (no atlas.yaml) nor a session directory (no session.yaml)");
  }
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto options = std::make_shared<RenderOptions>();
  CLI::App* command = app.add_subcommand(
      "render",
      "Draw a session (points, trajectory, magnetic samples) or an atlas (merged map with every "
      "connected session's trajectory in its own colour, plus the fused magnetic map)");
  command->add_option("input", options->input, "atlas directory (atlas.yaml) or session directory")
      ->required();
  command
      ->add_option("--out", options->out,
                   "PNG file to write; for an atlas, the fused magnetic map goes beside it as "
                   "<name>_magnetic.png")
      ->required();
  CLI::Option* scale =
      command->add_option("--pixels-per-metre", options->pixels_per_metre,
                          "picture scale (px/m; default 10 for maps, 20 for the magnetic map)");
  command->callback([options, scale] {
    options->scale_given = scale->count() > 0;
    runRender(*options);
  });
}

}  // namespace mm4mm::cli
