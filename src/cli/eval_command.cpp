// mm4mm eval: docs/design.md's three accuracy figures for an atlas whose sessions carry ground
// truth.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/input_error.hpp"

namespace mm4mm::cli {
namespace {

void runEval(const std::string& atlas_dir) {
  // Where each session went is all it needs: no readings, scans, edges or fused map are read.
  const Atlas atlas = loadAtlas(atlas_dir, SessionParts::kPoses);
  const std::vector<Session>& sessions = atlas.sessions;
  for (std::size_t s = 0; s < sessions.size(); ++s)
    if (!sessions[s].ground_truth)
      throw InputError(
          atlas.manifest.sessions[s].source.string(), 0,
          "session '" + sessions[s].id + "' has no ground_truth.txt to evaluate against");
  std::vector<const Session*> pointers;
  for (const Session& s : sessions) pointers.push_back(&s);
  const AtlasEvaluation evaluation =
      evaluateAtlas(pointers, atlas.T_atlas_keyframe, atlas.connected, atlas.frame_session);

  std::printf(
      "overlap error (median over keyframe pairs within 2 m; aligned below 0.5 m, 2 deg)\n");
  for (const auto& pair : evaluation.pairs)
    std::printf("  %s+%s: %.3f m, %.3f deg over %d keyframe pairs%s\n", sessions[pair.a].id.c_str(),
                sessions[pair.b].id.c_str(), pair.overlap.median_translation_m,
                pair.overlap.median_rotation_deg, pair.overlap.pairs,
                pair.overlap.aligned() ? "" : "  NOT ALIGNED");
  std::printf("paper's e_t / e_r of each session frame against %s\n",
              sessions[atlas.frame_session].id.c_str());
  for (const auto& frame : evaluation.frames)
    std::printf("  %s: %.3f m, %.3f deg\n", sessions[frame.session].id.c_str(),
                frame.error.translation_m, frame.error.rotation_deg);
  for (std::size_t s = 0; s < sessions.size(); ++s)
    if (!atlas.connected[s]) std::printf("  %s: not connected\n", sessions[s].id.c_str());
  // Two references, because the solve's ATE alone reads as worse than odometry wherever sessions
  // are placed through each other's drifted overlaps (the corridor demo): the same odometry at the
  // solve's session frames is what the graph improved on; at the true frames only drift counts,
  // which no merge can reach without knowing those frames.
  std::vector<Eigen::Isometry3d> T_atlas_session;
  for (const AtlasSessionEntry& entry : atlas.manifest.sessions)
    T_atlas_session.push_back(entry.T_atlas_session);
  const double placed_ate_m = atlasTrajectoryError(
      pointers, placeOdometry(pointers, T_atlas_session), atlas.connected, atlas.frame_session);
  std::printf("ATE (keyframe positions against ground truth in %s's frame)\n",
              sessions[atlas.frame_session].id.c_str());
  std::printf("  %.3f m after the solve\n", evaluation.ate_m);
  std::printf("  %.3f m for the raw odometry at the solve's session frames (no drift corrected)\n",
              placed_ate_m);
  std::printf(
      "  %.3f m for the raw odometry at the true session frames (drift only; frames a merge cannot "
      "know)\n",
      evaluation.odometry_ate_m);
}

}  // namespace

void addEvalCommand(CLI::App& app) {
  auto atlas = std::make_shared<std::string>();
  CLI::App* command = app.add_subcommand(
      "eval", "Accuracy of an atlas against the ground truth its sessions carry");
  command->add_option("atlas", *atlas, "atlas directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->callback([atlas] { runEval(*atlas); });
}

}  // namespace mm4mm::cli
