// mm4mm export octomap: the OctoMap of an atlas at its current poses, built on request. `add`
// leaves it out by default (it re-casts every scan of every session, the largest output cost of
// an add that grows with the atlas), so the atlas holds an octomap.bt only when it is current.

#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "mm4mm/atlas/atlas_outputs.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/octomap_io.hpp"

namespace mm4mm::cli {
namespace {

namespace fs = std::filesystem;

struct ExportOctoMapOptions {
  std::string atlas;
  std::string out;  // empty: into the atlas
  std::optional<double> resolution_m;
};

void runExportOctoMap(const ExportOctoMapOptions& options) {
  if (options.resolution_m && options.out.empty())
    throw std::invalid_argument(
        "--resolution needs --out: the atlas's own octomap.bt has the resolution of its "
        "config.yaml (outputs.octomap.resolution_m)");
  const fs::path atlas_dir = fs::absolute(options.atlas).lexically_normal();
  if (!options.out.empty()) {
    const fs::path out = fs::absolute(options.out).lexically_normal();
    const auto [end, unused] =
        std::mismatch(atlas_dir.begin(), atlas_dir.end(), out.begin(), out.end());
    (void)unused;
    if (end == atlas_dir.end())
      throw std::invalid_argument(
          "--out " + out.string() +
          " is inside the atlas, where files are the atlas's own: leave out --out to write the "
          "atlas's octomap.bt");
  }
  // A directory that is no atlas gets no lock file beside it: said before the lock.
  if (!fs::exists(atlas_dir / "atlas.yaml")) readAtlasManifest(atlas_dir);
  // Into the atlas: held from reading it to swapping in the new one, so an add cannot slip in
  // between and have its sessions drawn at the old poses.
  std::optional<AtlasWriteLock> lock;
  if (options.out.empty()) lock.emplace(atlas_dir);
  AtlasManifest manifest = readAtlasManifest(atlas_dir);
  std::vector<fs::path> dirs;
  for (const AtlasSessionEntry& entry : manifest.sessions) dirs.push_back(entry.source);
  checkMemory(dirs, "the OctoMap of " + std::to_string(dirs.size()) + " sessions", std::nullopt);
  Atlas atlas = loadAtlas(atlas_dir, std::move(manifest));
  OctoMapConfig config = atlas.manifest.config.outputs.octomap;
  if (options.resolution_m) config.resolution_m = *options.resolution_m;
  std::string problem;
  if (!config.IsValid(&problem)) throw std::invalid_argument("--resolution: " + problem);
  // The unconnected sessions, which have no place in the atlas frame, are dropped here, so that
  // the connected ones are not copied to leave them out.
  std::vector<Session> placed;
  std::vector<std::vector<Eigen::Isometry3d>> poses;
  for (std::size_t s = 0; s < atlas.sessions.size(); ++s)
    if (atlas.connected[s]) {
      placed.push_back(std::move(atlas.sessions[s]));
      poses.push_back(std::move(atlas.T_atlas_keyframe[s]));
    }
  const std::optional<OctoMapTree> tree =
      buildAtlasOctoMap(placed, poses, std::vector<bool>(placed.size(), true), config);
  if (!tree)
    throw InputError((atlas_dir / "atlas.yaml").string(), 0,
                     "no connected session of the atlas has LiDAR scans: there is no OctoMap to "
                     "build");
  if (options.out.empty())
    writeAtlasOctoMap(atlas_dir, *tree);
  else
    writeOctoMap(options.out, *tree);
  spdlog::info("wrote {}: octomap of {} nodes at {} m from {} scans in {:.1f} s",
               options.out.empty() ? (atlas_dir / "octomap.bt").string() : options.out,
               tree->stats.nodes, tree->resolution_m, tree->stats.scans, tree->stats.seconds);
}

}  // namespace

void addExportCommand(CLI::App& app) {
  CLI::App* command =
      app.add_subcommand("export", "Build an output of an atlas on request (octomap)");
  command->require_subcommand(1);
  auto options = std::make_shared<ExportOctoMapOptions>();
  CLI::App* octomap = command->add_subcommand(
      "octomap",
      "The OctoMap of an atlas at its current poses: into the atlas as octomap.bt (add leaves it "
      "out unless --octomap), or to --out");
  octomap->add_option("atlas", options->atlas, "atlas directory (written by merge or add)")
      ->required()
      ->check(CLI::ExistingDirectory);
  octomap->add_option("--out", options->out,
                      "write the .bt file here instead of into the atlas (the atlas is unchanged)");
  octomap->add_option("--resolution", options->resolution_m,
                      "leaf size (m) of the --out file (default: the atlas's "
                      "outputs.octomap.resolution_m)");
  octomap->callback([options] { runExportOctoMap(*options); });
}

}  // namespace mm4mm::cli
