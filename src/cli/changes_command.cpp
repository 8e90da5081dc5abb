// mm4mm changes: where the field changed between an atlas's sessions (issue 18), as the last merge
// or add found it: the regions report.json lists, or only those of one session, and on request a
// picture of the fused map with them outlined. Reads the atlas, computes nothing.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"
#include "mm4mm/merge/magnetic_change.hpp"
#include "mm4mm/render/magnetic_map_render.hpp"

namespace mm4mm::cli {
namespace {

namespace fs = std::filesystem;

struct ChangesOptions {
  std::string atlas;
  std::string session;  // empty: every session's regions
  std::string png;      // empty: no picture
};

std::string joined(const std::vector<std::string>& ids) {
  std::string text;
  for (const std::string& id : ids) text += (text.empty() ? "" : ", ") + id;
  return text;
}

// The fused map with the shown regions outlined and numbered as report.json numbers them.
void drawChanges(const fs::path& dir, const ReportedChanges& changes,
                 const std::vector<bool>& shown, const std::string& title, const fs::path& png) {
  if (!fs::exists(dir / "magnetic_map.pcd"))
    throw InputError((dir / "magnetic_map.pcd").string(), 0,
                     "not found: the atlas has no fused magnetic map to draw the changes on");
  const MagneticMap fused = readMagneticMapPcd(dir / "magnetic_map.pcd");
  MapRegionOverlay overlay;
  overlay.of_cell.assign(static_cast<std::size_t>(fused.width) * fused.height, 0);
  const fs::path change_file = dir / "changes" / "magnetic_change.pcd";
  if (fs::exists(change_file)) {
    const ChangeMap cells = readChangeMapPcd(change_file);
    if (cells.width != fused.width || cells.height != fused.height ||
        cells.cell_size_m != fused.cell_size_m || cells.origin_m != fused.origin_m)
      throw InputError(change_file.string(), 0,
                       "its grid is not the fused map's (magnetic_map.pcd): not this atlas's");
    overlay.of_cell = placesOfRegions(cells, shown);
  }
  const Eigen::Vector2d nowhere =
      Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < changes.regions.size(); ++k)
    overlay.label_at_m.push_back(shown[k] ? changes.regions[k].region.centroid_m : nowhere);
  MagneticMapRenderOptions options;
  options.title = title;
  renderMagneticMapPng(fused, options, png, &overlay);
}

void runChanges(const ChangesOptions& options) {
  const fs::path dir = fs::absolute(options.atlas).lexically_normal();
  const AtlasManifest manifest = readAtlasManifest(dir);  // a damaged atlas is refused here
  std::vector<std::string> ids;
  for (const AtlasSessionEntry& entry : manifest.sessions) ids.push_back(entry.id);
  if (!options.session.empty() && std::find(ids.begin(), ids.end(), options.session) == ids.end())
    throw InputError(
        (dir / "atlas.yaml").string(), 0,
        "no session '" + options.session + "' in the atlas (its sessions: " + joined(ids) + ")");
  const ReportedChanges changes = readAtlasReportChanges(dir / "report.json");

  std::vector<bool> shown(changes.regions.size());
  std::size_t count = 0;
  for (std::size_t k = 0; k < changes.regions.size(); ++k) {
    const ReportedChanges::Region& r = changes.regions[k];
    shown[k] = options.session.empty() || r.a == options.session || r.b == options.session;
    if (!shown[k]) continue;
    ++count;
    std::printf("%s\n", changeLine(k + 1, r.a, r.b, r.region).c_str());
  }
  if (!changes.calibration_unchecked.empty())
    std::printf(
        "%s not compared (magnetometer calibration with no place passed twice at headings "
        "apart)\n",
        joined(changes.calibration_unchecked).c_str());
  const bool all_of = changes.pairs_of.size() == ids.size() || changes.pairs_of.empty();
  std::printf("%zu region(s)%s; %zu pair(s) of sessions compared%s\n", count,
              options.session.empty() ? "" : (" with " + options.session).c_str(),
              changes.pairs_compared,
              all_of ? "" : (" by the last add, those with " + joined(changes.pairs_of)).c_str());
  if (options.png.empty()) return;
  drawChanges(dir, changes, shown,
              "changes" + (options.session.empty() ? std::string() : " with " + options.session) +
                  " on the fused magnetic map",
              options.png);
  std::printf("wrote %s\n", options.png.c_str());
}

}  // namespace

std::string changeLine(std::size_t number, const std::string& a, const std::string& b,
                       const MagneticChangeRegion& region) {
  char line[320];
  std::snprintf(line, sizeof line,
                "change %zu: %s+%s: the field differs over %.1f m² at (%.1f, %.1f) m in the atlas "
                "frame, by %.1f µT on average (%.1f at most)",
                number, a.c_str(), b.c_str(), region.area_m2, region.centroid_m.x(),
                region.centroid_m.y(), region.mean_delta_uT, region.max_delta_uT);
  return line;
}

void addChangesCommand(CLI::App& app) {
  auto options = std::make_shared<ChangesOptions>();
  CLI::App* command = app.add_subcommand(
      "changes", "Where the magnetic field changed between an atlas's sessions (report.json)");
  command->add_option("atlas", options->atlas, "atlas directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--session", options->session,
                      "only the regions where this session's field differs from another's");
  command->add_option("--png", options->png,
                      "draw the fused magnetic map with the regions outlined into this file");
  command->callback([options] { runChanges(*options); });
}

}  // namespace mm4mm::cli
