// mm4mm simulate: writes DIR/s0 … DIR/s<N-1>, one session directory each, with ground truth.

#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <memory>

#include "commands.hpp"
#include "mm4mm/io/change_truth_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "mm4mm/sim/world_change.hpp"

namespace mm4mm::cli {
namespace {

struct SimulateOptions {
  std::string world;
  int sessions = 0;
  std::uint64_t seed = 0;
  std::string out;
  std::string config;
  bool disjoint = false;
};

void runSimulate(const SimulateOptions& options) {
  sim::SimulationConfig config;
  if (!options.config.empty()) config = loadSimulationConfig(options.config);
  if (!options.world.empty()) config.world = options.world;
  if (options.disjoint) config.layout.disjoint_session = true;
  std::string problem;
  if (!config.IsValid(&problem)) throw std::invalid_argument("simulation settings: " + problem);
  // The paper's set-ups: 4 warehouse sessions, 3 corridor sessions (one more if disjoint).
  int count = options.sessions;
  if (count <= 0)
    count = (config.world == "corridor" ? 3 : 4) + (config.layout.disjoint_session ? 1 : 0);

  if (config.change.first_session >= count)
    throw std::invalid_argument("simulation settings: change.first_session is " +
                                std::to_string(config.change.first_session) + " but only " +
                                std::to_string(count) + " sessions are simulated");
  spdlog::info("simulating {} {} sessions (layout {}{}), seed {}", count, config.world,
               config.layoutMode(), config.layout.disjoint_session ? ", last one disjoint" : "",
               options.seed);
  const auto start = std::chrono::steady_clock::now();
  const sim::ChangingWorld worlds(config, options.seed);
  const sim::World& world = worlds.whole().world;
  if (config.world == "procedural")
    spdlog::info("building: {}, {:.0f} m x {:.0f} m, {} steel dipoles", world.name,
                 world.floor_xy.sizes().x(), world.floor_xy.sizes().y(), world.dipoles.size());
  const auto routes = sim::planSessionRoutes(world, config, count, options.seed);
  const std::filesystem::path out(options.out);
  std::filesystem::create_directories(out);
  if (worlds.changes()) {
    const sim::ChangeTruth truth =
        sim::changeTruth(worlds.before().field, worlds.after().field, config.change,
                         config.rig.magnetometer_height_m);
    writeChangeTruth(out, config.change, world, truth);
    spdlog::info(
        "the building changes before s{}: {} box(es) taken away, {} brought in; the field "
        "changes by {:.1f} uT at most, by {:.1f} uT or more over {:.1f} m2 (change.yaml, "
        "change_truth.pcd)",
        config.change.first_session, config.change.removed_m.size(), config.change.added_m.size(),
        truth.largest_uT, config.change.truth_threshold_uT, truth.changed_area_m2);
  }
  for (int k = 0; k < count; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string id = "s" + std::to_string(k);
    const Session session = sim::simulateSession(worlds.forSession(k), routes[k], config, id,
                                                 sim::deriveSeed(options.seed, 100 + k));
    const auto t1 = std::chrono::steady_clock::now();
    writeSession(session, out / id);
    const auto t2 = std::chrono::steady_clock::now();
    spdlog::info(
        "{}: {:.0f} m, {} keyframes, {} magnetometer samples; simulated in {:.2f} s, "
        "written in {:.2f} s",
        id, routes[k].length(), session.keyframes.size(), session.magnetometer.size(),
        std::chrono::duration<double>(t1 - t0).count(),
        std::chrono::duration<double>(t2 - t1).count());
  }
  spdlog::info("wrote {} sessions to {} in {:.1f} s", count, out.string(),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
}

}  // namespace

void addSimulateCommand(CLI::App& app) {
  auto options = std::make_shared<SimulateOptions>();
  CLI::App* command = app.add_subcommand(
      "simulate", "Simulate multi-session data with ground truth in an ambiguous world");
  command
      ->add_option("--world", options->world,
                   "warehouse, corridor or procedural (a building drawn from the seed; "
                   "procedural.building in the config picks its type) (default: the config's)")
      ->check(CLI::IsMember({"warehouse", "corridor", "procedural"}));
  command
      ->add_option("--sessions", options->sessions,
                   "number of sessions (default: 4 warehouse, 3 corridor)")
      ->check(CLI::Range(1, 1000));
  command->add_option("--seed", options->seed, "random seed; same seed, same sessions");
  command->add_option("--out", options->out, "output directory for s0 … s<N-1>")->required();
  command->add_option("--config", options->config, "YAML preset overriding the defaults")
      ->check(CLI::ExistingFile);
  command->add_flag("--disjoint", options->disjoint,
                    "make the last session overlap no other session");
  command->callback([options] { runSimulate(*options); });
}

}  // namespace mm4mm::cli
