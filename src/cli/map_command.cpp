// mm4mm map: the single-session magnetic map and point map of one session directory.

#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.hpp"
#include "mm4mm/geometry/point_map.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"
#include "mm4mm/io/point_map_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/render/magnetic_map_render.hpp"

namespace mm4mm::cli {
namespace {

namespace fs = std::filesystem;

struct MapOptions {
  std::string session;
  std::string out;     // empty: SESSION/map
  std::string config;  // its merge.matcher.calibration and merge.matcher.map
  double cell_size_m = MagneticMapConfig{}.cell_size_m;
  bool cell_size_given = false;
  PointMapConfig points;
};

class Stopwatch {
 public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return seconds;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

void runMap(const MapOptions& options) {
  MagneticMatcherConfig matcher;
  if (!options.config.empty()) matcher = loadPipelineConfig(options.config).merge.matcher;
  MagneticMapConfig magnetic_config = matcher.map;
  if (options.cell_size_given || options.config.empty())
    magnetic_config.cell_size_m = options.cell_size_m;
  std::string problem;
  if (!magnetic_config.IsValid(&problem)) throw std::invalid_argument("--cell-size: " + problem);
  if (!options.points.IsValid(&problem)) throw std::invalid_argument("--voxel-size: " + problem);
  const fs::path dir(options.session);
  if (!fs::is_directory(dir) || !fs::exists(dir / "session.yaml"))
    throw InputError(options.session, 0, "not a session directory (no session.yaml)");
  const fs::path out = options.out.empty() ? dir / "map" : fs::path(options.out);
  if (fs::exists(out) && !fs::is_directory(out))
    throw InputError(out.string(), 0, "--out names a file, not a directory");

  Stopwatch clock;
  Session session = readSession(dir);
  spdlog::info("read session {}: {} keyframes, {} magnetometer samples, {} ({:.1f} s)", session.id,
               session.keyframes.size(), session.magnetometer.size(),
               session.hasScans() ? std::to_string(session.scans.size()) + " scans"
                                  : std::string("magnetic-only"),
               clock.lap());

  const std::vector<SessionCalibration> calibration =
      calibrateAndLog({&session}, matcher.calibration);
  spdlog::info("calibration ({:.2f} s): field spread {:.1f} µT, correlation length {:.2f} m",
               calibration.front().seconds, calibration.front().field_spread_uT,
               calibration.front().field_correlation_length_m);
  const MagneticMap magnetic =
      buildMagneticMap(placeFingerprints(session), session.rig, magnetic_config);
  if (magnetic.coveredCells() == 0)
    throw InputError(
        options.session, 0,
        "no magnetometer sample falls within the keyframes' time span; nothing to map");
  spdlog::info("magnetic map: {} x {} cells of {} m, {} covered ({:.1f} s)", magnetic.width,
               magnetic.height, magnetic.cell_size_m, magnetic.coveredCells(), clock.lap());

  PointMap points;
  if (session.hasScans()) {
    spdlog::info("point map: voxelising the scans at {} m and fitting covariances ...",
                 options.points.voxel_size_m);
    points = buildPointMap(session, options.points);
    spdlog::info("point map: {} scan points -> {} points ({:.1f} s)", points.input_points,
                 points.size(), clock.lap());
  }

  fs::create_directories(out);
  writeMagneticMapPcd(out / "magnetic_map.pcd", magnetic);
  MagneticMapRenderOptions render;
  render.title = "session " + session.id;
  renderMagneticMapPng(magnetic, render, out / "magnetic_map.png");
  if (session.hasScans()) {
    writePointMapPcd(out / "point_map.pcd", points);
  } else {
    // A point map left by an earlier run would no longer describe this session's output.
    fs::remove(out / "point_map.pcd");
    spdlog::info("magnetic-only session: no point map");
  }
  spdlog::info("wrote {} ({:.1f} s)", out.string(), clock.lap());
  spdlog::info("summary: {:.1f} m² covered magnetically in {} cells of {} m; {} map points",
               magnetic.coveredArea_m2(), magnetic.coveredCells(), magnetic.cell_size_m,
               points.size());
}

}  // namespace

void addMapCommand(CLI::App& app) {
  auto options = std::make_shared<MapOptions>();
  CLI::App* command = app.add_subcommand(
      "map",
      "Build one session's magnetic map and point map (magnetic_map.pcd/.png, point_map.pcd)");
  command->add_option("session", options->session, "session directory")->required();
  command->add_option("--out", options->out, "output directory (default: SESSION/map)");
  command->add_option("--cell-size", options->cell_size_m, "magnetic map cell size (m)")
      ->capture_default_str();
  command
      ->add_option("--config", options->config,
                   "config YAML (configs/mm4mm.yaml) whose merge.matcher.calibration and "
                   "merge.matcher.map set the calibration and the magnetic map")
      ->check(CLI::ExistingFile);
  command->add_option("--voxel-size", options->points.voxel_size_m, "point map voxel size (m)")
      ->capture_default_str();
  command->callback([options, command] {
    options->cell_size_given = command->count("--cell-size") > 0;
    runMap(*options);
  });
}

}  // namespace mm4mm::cli
