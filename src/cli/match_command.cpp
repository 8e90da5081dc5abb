// mm4mm match: the relative pose of two sessions from the magnetic field alone, or a refusal.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/match_json.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"

namespace mm4mm::cli {
namespace {

struct MatchOptions {
  std::string a, b, config;
  bool json = false;
};

int runMatch(const MatchOptions& options) {
  const MagneticMatcherConfig config = options.config.empty()
                                           ? MagneticMatcherConfig{}
                                           : loadPipelineConfig(options.config).merge.matcher;
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
  const MagneticMatchResult r = matchSessions(a, b, config);
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
  command
      ->add_option("--config", options->config,
                   "config YAML (configs/mm4mm.yaml); its merge.matcher settings")
      ->check(CLI::ExistingFile);
  command->callback([options] {
    const int code = runMatch(*options);
    if (code != kSuccess) throw CLI::RuntimeError(code);
  });
}

}  // namespace mm4mm::cli
