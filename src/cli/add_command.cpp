// mm4mm add: one more session into an existing atlas, which is rewritten whole or not at all.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "mm4mm/atlas/add_session.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"

namespace mm4mm::cli {
namespace {

namespace fs = std::filesystem;

struct AddOptions {
  std::string atlas;
  std::string session;
  std::string config;  // empty: the atlas's own
  bool no_magnetic_residuals = false;
  bool octomap = false;
  std::optional<double> memory_limit_gib;
};

// The settings of this add: the atlas's own unless a config file is given, then the flags.
PipelineConfig addConfig(const AddOptions& options, const AtlasManifest& manifest,
                         const std::optional<PipelineConfig>& file) {
  PipelineConfig config = manifest.config;
  if (!manifest.config_stored)
    spdlog::info(
        "{} was written before atlases kept their settings: running with the defaults and its "
        "OctoMap resolution ({} m)",
        options.atlas, manifest.config.outputs.octomap.resolution_m);
  if (file) {
    if (pipelineConfigYaml(*file) != pipelineConfigYaml(config))
      std::printf("this add runs with the settings of %s, not those %s was built with\n",
                  options.config.c_str(), options.atlas.c_str());
    config = *file;
  }
  if (options.no_magnetic_residuals) config.merge.graph.use_magnetic_residuals = false;
  std::string problem;
  if (!config.IsValid(&problem)) throw std::invalid_argument(problem);
  return config;
}

void runAdd(const AddOptions& options) {
  // Read before the lock, so that a bad file is said at once.
  std::optional<PipelineConfig> file;
  if (!options.config.empty()) file = loadPipelineConfig(options.config);

  // A directory that is no atlas gets no lock file beside it: said before the lock.
  if (!fs::exists(fs::path(options.atlas) / "atlas.yaml")) readAtlasManifest(options.atlas);
  // Held from reading the atlas to swapping in the new one: a concurrent add is refused rather than
  // starting from the same atlas and losing one of the two sessions.
  const AtlasWriteLock lock(options.atlas);
  AtlasManifest manifest = readAtlasManifest(options.atlas);
  // Every session of the atlas is read with its scans, and the new one: refused with the figure,
  // before any is read, where they would not fit.
  std::vector<fs::path> dirs;
  for (const AtlasSessionEntry& entry : manifest.sessions) dirs.push_back(entry.source);
  dirs.emplace_back(options.session);
  checkMemory(dirs, "adding a session to " + std::to_string(dirs.size() - 1) + " in the atlas",
              options.memory_limit_gib);
  Atlas atlas = loadAtlas(options.atlas, std::move(manifest));
  const PipelineConfig pipeline = addConfig(options, atlas.manifest, file);
  const MergeConfig& config = pipeline.merge;
  const fs::path source = fs::absolute(options.session).lexically_normal();
  for (const AtlasSessionEntry& entry : atlas.manifest.sessions)
    if (fs::absolute(entry.source).lexically_normal() == source)
      throw InputError(options.session, 0,
                       "this session directory is already in the atlas (as '" + entry.id + "')");
  Session session = readSessionDir(options.session);
  spdlog::info("atlas {}: {} session{}; adding {} ({} keyframes, {} magnetometer samples{})",
               options.atlas, atlas.sessions.size(), atlas.sessions.size() == 1 ? "" : "s",
               session.id, session.keyframes.size(), session.magnetometer.size(),
               session.hasScans() ? "" : ", no scans");
  // The atlas's sessions are read from their sources as they are: calibrated again here, with the
  // same result as when they were merged (the step is deterministic).
  std::vector<Session*> pointers;
  for (Session& s : atlas.sessions) pointers.push_back(&s);
  pointers.push_back(&session);
  const std::vector<SessionCalibration> calibrations =
      calibrateAndLog(pointers, config.matcher.calibration);
  MergeResult result = addSessionToAtlas(atlas, session, config,
                                         [](const std::string& message) { spdlog::info(message); });
  result.calibrations = calibrations;

  std::vector<fs::path> sources;
  for (const AtlasSessionEntry& entry : atlas.manifest.sessions) sources.push_back(entry.source);
  sources.push_back(source);
  atlas.sessions.push_back(std::move(session));
  // The pairs among the atlas's sessions were compared when each came in: an add compares the
  // new session with the others, a comparison per session in the atlas, not per pair.
  std::vector<bool> changes_of(atlas.sessions.size(), false);
  changes_of.back() = true;
  const AtlasOutputs built = buildAtlasOutputs(
      atlas.sessions, result, pipeline.outputs,
      options.octomap ? OctoMapBuild::kBuild : OctoMapBuild::kLeaveOut, changes_of);
  const AtlasWriteTimings timings =
      writeAtlas(options.atlas, atlas.sessions, sources, result, built, picturesOf(built));
  spdlog::info("rewrote {} in {:.1f} s", options.atlas, timings.total_s);
  if (built.octomap_left_out)
    std::printf(
        "octomap.bt left out (it re-casts every session's scans): `mm4mm export octomap %s` "
        "builds it, or add with --octomap\n",
        options.atlas.c_str());
  printConnections(atlas.sessions, result, false);
  printLeftOutOfTheFusedMap(atlas.sessions, built);
  printChanges(atlas.sessions, built);
}

}  // namespace

void addAddCommand(CLI::App& app) {
  auto options = std::make_shared<AddOptions>();
  CLI::App* command = app.add_subcommand(
      "add", "Add one session to an atlas: match it against the atlas, refine, solve, rewrite");
  command->add_option("atlas", options->atlas, "atlas directory (written by merge or add)")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("session", options->session, "session directory to add")
      ->required()
      ->check(CLI::ExistingDirectory);
  command
      ->add_option("--config", options->config,
                   "config YAML to run with instead of the settings the atlas was built with")
      ->check(CLI::ExistingFile);
  command->add_flag("--no-magnetic-residuals", options->no_magnetic_residuals,
                    "solve the graph without the magnetic residuals");
  addMemoryLimitOption(command, &options->memory_limit_gib);
  command->add_flag("--octomap", options->octomap,
                    "rebuild octomap.bt as well (left out by default: it re-casts every "
                    "session's scans; `mm4mm export octomap ATLAS` builds it on request)");
  command->callback([options] { runAdd(*options); });
}

}  // namespace mm4mm::cli
