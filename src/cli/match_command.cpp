// mm4mm match: the relative pose of two sessions from the magnetic field alone, or a refusal.

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/match_json.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/merge/merge_steps.hpp"

namespace mm4mm::cli {
namespace {

struct MatchOptions {
  std::string a, b, config;
  bool json = false;
  bool across_heights = false;
};

int runMatch(const MatchOptions& options) {
  const MergeConfig merge =
      options.config.empty() ? MergeConfig{} : loadPipelineConfig(options.config).merge;
  const MagneticMatcherConfig& config = merge.matcher;
  Session a = readSessionDir(options.a);
  Session b = readSessionDir(options.b);
  if (options.json) {
    calibrateSessions({&a, &b}, config.calibration);
  } else {
    calibrateAndLog({&a, &b}, config.calibration);
  }
  if (!options.json)
    spdlog::info("matching {} ({} samples) with {} ({} samples)", a.id, a.magnetometer.size(), b.id,
                 b.magnetometer.size());
  // As merge does: the field near the floor changes with height, so two sessions whose
  // magnetometers are at different heights are not compared by it (MergeConfig).
  const auto start = std::chrono::steady_clock::now();
  const SessionMaps maps = buildSessionMaps({&a, &b}, merge);  // calibrated above, as merge does
  if (const std::optional<double> difference =
          heightMismatch(maps, 0, 1, merge.max_height_difference_m);
      difference && !options.across_heights) {
    char text[300];
    std::snprintf(text, sizeof text,
                  "%s's magnetometers are %.2f m %s %s's: the field is not compared across more "
                  "than %.2f m of height (merge.max_height_difference_m; --across-heights compares "
                  "it anyway)",
                  b.id.c_str(), std::abs(*difference), *difference < 0 ? "above" : "below",
                  a.id.c_str(), merge.max_height_difference_m);
    if (options.json)
      std::printf("%s\n", nlohmann::json({{"verdict", "not_compared"},
                                          {"height_difference_m", *difference},
                                          {"reason", text}})
                              .dump(2)
                              .c_str());
    else
      std::printf("not compared: %s\n", text);
    return kNoOverlap;
  }
  const double maps_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MagneticMatchResult r = matchMagneticMaps(maps.magnetic[0], maps.magnetic[1], config);
  r.stage_seconds.maps = maps_seconds;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (options.json) {
    std::printf("%s\n", matchResultJson(r).c_str());
  } else {
    std::printf(
        "%s: z %.1f, r %.3f over %.0f m², second mode ratio %.2f, yaw known to ±%.1f deg, "
        "probability %.2f, %.2f s\n",
        toString(r.verdict).c_str(), r.z, r.r, r.overlap_m2, r.second_mode_ratio,
        r.yaw_uncertainty_deg, r.probability, r.seconds);
    std::printf("%s T_%s_%s: x %.3f m, y %.3f m, yaw %.2f deg\n", r.overlap() ? "" : "(refused)",
                a.id.c_str(), b.id.c_str(), r.T_a_b.x_m, r.T_a_b.y_m,
                r.T_a_b.yaw_rad * 180.0 / M_PI);
  }
  return r.overlap() ? kSuccess : kNoOverlap;
}

}  // namespace

std::vector<SessionCalibration> calibrateAndLog(const std::vector<Session*>& sessions,
                                                const CalibrationConfig& config) {
  const std::vector<SessionCalibration> records = calibrateSessions(sessions, config);
  for (std::size_t i = 0; i < sessions.size(); ++i)
    for (std::size_t k = 0; k < records[i].sensors.size(); ++k)
      spdlog::info("{} magnetometer {}: {}", sessions[i]->id, k, describe(records[i].sensors[k]));
  return records;
}

Session readSessionDir(const std::string& path) {
  if (!std::filesystem::exists(std::filesystem::path(path) / "session.yaml"))
    throw InputError(path, 0, "not a session directory (no session.yaml)");
  return readSession(path);
}

void addMatchCommand(CLI::App& app) {
  auto options = std::make_shared<MatchOptions>();
  CLI::App* command = app.add_subcommand(
      "match", "Find T_A_B of two sessions from the magnetic field, or answer no overlap");
  command->add_option("session_a", options->a, "session directory A (the target frame)")
      ->required();
  command->add_option("session_b", options->b, "session directory B")->required();
  command->add_flag("--json", options->json, "print the result as JSON");
  command->add_flag("--across-heights", options->across_heights,
                    "compare the field even where the sessions' magnetometers are at different "
                    "heights above the floor");
  command
      ->add_option("--config", options->config,
                   "config YAML (configs/mm4mm.yaml); its merge.matcher and "
                   "merge.max_height_difference_m settings")
      ->check(CLI::ExistingFile);
  command->callback([options] {
    const int code = runMatch(*options);
    if (code != kSuccess) throw CLI::RuntimeError(code);
  });
}

}  // namespace mm4mm::cli
