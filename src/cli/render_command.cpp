// mm4mm render: top-down pictures of a session, or of an atlas (merged map, fused magnetic map,
// and where its sessions disagree before and after their field offsets).

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/merge/field_offsets.hpp"
#include "mm4mm/merge/fused_magnetic_map.hpp"
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

// X.png -> X_seams_before.png / X_seams_after.png, beside it.
fs::path seamsPicturePath(const fs::path& out, const std::string& when) {
  return out.parent_path() / (out.stem().string() + "_seams_" + when + out.extension().string());
}

// Where the placed sessions disagree (issue 32): at each cell two or more of them cover, the
// largest B_F difference between them, with the layers as calibrated alone and with the field
// offsets the fused map applies, on one colour scale (0 to the 98th percentile before), so the
// seams that the offsets remove show as colour going to dark.
void renderSeams(const Atlas& atlas, const std::string& name, const RenderOptions& options,
                 const fs::path& out) {
  const FusedMagneticMapConfig& config = atlas.manifest.config.outputs.magnetic;
  std::vector<MagneticLayer> layers;
  for (std::size_t s = 0; s < atlas.sessions.size(); ++s)
    if (atlas.connected[s])
      layers.push_back(buildMagneticLayer(atlas.sessions[s], atlas.T_atlas_keyframe[s], config));
  const FusedMagneticMap before = fuseMagneticLayers(layers);
  std::vector<float> spread_before;
  for (const float v : before.spread_total_uT)
    if (std::isfinite(v)) spread_before.push_back(v);
  if (spread_before.empty()) {
    spdlog::info("no two placed sessions cover a common cell; no seams pictures");
    return;
  }
  const FieldOffsets offsets = applyFieldOffsets(layers, config.offsets);
  const FusedMagneticMap after = fuseMagneticLayers(layers);
  const auto p98 =
      spread_before.begin() + static_cast<std::ptrdiff_t>(0.98 * (spread_before.size() - 1));
  std::nth_element(spread_before.begin(), p98, spread_before.end());

  for (const auto& [fused, when] : {std::pair{&before, "before"}, std::pair{&after, "after"}}) {
    // The picture's cells are the shared ones, holding their spread.
    MagneticMap seams = fused->map;
    seams.total_uT = fused->spread_total_uT;
    MagneticMapRenderOptions render;
    render.title = name + ": the largest difference between sessions " +
                   (std::string(when) == "before"
                        ? "as calibrated alone"
                        : "with their field offsets (" + std::to_string(offsets.pairs.size()) +
                              " pairs solved)");
    render.value_label = "\u0394B_F";
    render.colour_low_uT = 0.0;
    render.colour_high_uT = std::max(static_cast<double>(*p98), 1.0);
    if (options.scale_given) render.pixels_per_metre = options.pixels_per_metre;
    const fs::path path = seamsPicturePath(out, when);
    renderMagneticMapPng(seams, render, path);
    std::printf("%s\n", path.c_str());
  }
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
  // Quoted: an atlas directory is often named "atlas", and "atlas atlas" read as a typo.
  const std::string name = "atlas '" + directoryName(dir) + "'";
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
  renderSeams(atlas, name, options, out);
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
      "connected session's trajectory in its own colour, plus the fused magnetic map and its "
      "seams between sessions)");
  command->add_option("input", options->input, "atlas directory (atlas.yaml) or session directory")
      ->required();
  command
      ->add_option("--out", options->out,
                   "PNG file to write; for an atlas, the fused magnetic map goes beside it as "
                   "<name>_magnetic.png, and where its sessions disagree before and after the "
                   "field offsets as <name>_seams_before.png and <name>_seams_after.png")
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
