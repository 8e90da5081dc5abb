// How well a session's scans tell its frame's height above the floor (geometry/floor_height):
// what merge uses where session.yaml states none, to keep sessions whose magnetometers are at
// other heights from being compared by the field. Per preset, rig and seed, every simulated
// session (the simulator's frame starts on the floor: 0 is the truth) and the same session with
// its frame raised by each of --raised (the body below the frame's origin by that much, as a
// LiDAR-inertial odometry's frame at the LiDAR has it). Rows: the estimate against the truth.
//
// With --real-scan-pair DIR (../shared/data/koide-gicp-lidar-scan-pair/small_gicp), also each real
// scan of that pair as a one-keyframe session (preset "real", rig "lidar", seed 0): there is no
// truth, so the row says whether a floor was found and, found or not, the estimate and the
// contrast the floor rule would have seen (min_floor_contrast 0).
//
// Usage: floor_height_bench [--seeds N] [--first-seed S] [--presets a,b,...] [--rigs a,b,...]
//                           [--raised 0,0.6,...] [--real-scan-pair DIR] [--csv FILE]
// CSV (appended, header when new; a preset, rig and seed already in it is skipped, so a cut run
// resumes): preset, rig, seed, session, true frame height (m, empty where unknown), estimate (m,
// empty where none), error (m), floor points, keyframes read, contrast, found (0/1).

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "bench_util.hpp"
#include "mm4mm/geometry/floor_height.hpp"
#include "mm4mm/io/ply_io.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "sim_presets.hpp"

using namespace mm4mm;
using namespace mm4mm::bench;
namespace fs = std::filesystem;

namespace {

// The frame's origin `height_m` higher: the body is that far below it.
Session withFrameRaised(Session session, double height_m) {
  for (StampedPose& k : session.keyframes) k.T_frame_body.translation().z() -= height_m;
  session.rig.frame_height_above_floor_m.reset();
  return session;
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 5, first_seed = 1;
  std::vector<std::string> presets{"warehouse", "corridor", "procedural"};
  std::vector<std::string> rigs{"imu", "husky3", "array7", "handheld"};
  std::vector<std::string> raised_list{"0", "0.6", "1.5"};
  std::string csv_path = "floor_height.csv", real_pair;
  for (const auto& [flag, value] :
       parseFlags(argc, argv,
                  {"--seeds", "--first-seed", "--presets", "--rigs", "--raised", "--real-scan-pair",
                   "--csv"},
                  "floor_height_bench [--seeds N] [--first-seed S] [--presets a,b,...] "
                  "[--rigs a,b,...] [--raised 0,0.6,...] [--real-scan-pair DIR] [--csv FILE]")) {
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--presets") presets = splitList(value);
    if (flag == "--rigs") rigs = splitList(value);
    if (flag == "--raised") raised_list = splitList(value);
    if (flag == "--real-scan-pair") real_pair = value;
    if (flag == "--csv") csv_path = value;
  }
  const std::set<std::string> done = casesDone(csv_path);
  const bool fresh = !fs::exists(csv_path);
  std::FILE* csv = std::fopen(csv_path.c_str(), "a");
  if (!csv) {
    std::fprintf(stderr, "floor_height_bench: cannot open %s\n", csv_path.c_str());
    return 1;
  }
  if (fresh)
    std::fprintf(
        csv,
        "preset,rig,seed,session,true_m,estimate_m,error_m,floor_points,keyframes,contrast,"
        "found\n");
  for (const std::string& preset_name : presets)
    for (const std::string& rig : rigs)
      for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
        const std::string key = preset_name + "," + rig + "," + std::to_string(seed);
        if (done.count(key)) continue;
        Preset preset = presetFor(preset_name);
        sim::applyRigPreset(rig, &preset.config);
        const std::vector<Session> sessions =
            sim::simulateSessions(preset.config, preset.sessions, seed);
        for (const Session& session : sessions)
          for (const std::string& text : raised_list) {
            const double raised = std::stod(text);
            const std::optional<FloorHeight> floor =
                floorHeightFromScans(withFrameRaised(session, raised));
            if (floor)
              std::fprintf(csv, "%s,%s,%.3f,%.4f,%.4f,%d,%d,%.2f,1\n", key.c_str(),
                           session.id.c_str(), raised, floor->frame_height_m,
                           floor->frame_height_m - raised, floor->floor_points, floor->keyframes,
                           floor->contrast);
            else
              std::fprintf(csv, "%s,%s,%.3f,,,0,0,,0\n", key.c_str(), session.id.c_str(), raised);
          }
        std::fflush(csv);
        std::fprintf(stderr, "%s done\n", key.c_str());
      }
  if (!real_pair.empty() && !done.count("real,lidar,0"))
    for (const char* name : {"target", "source"}) {
      Session session;
      session.id = name;
      session.keyframes.push_back({0.0, Eigen::Isometry3d::Identity()});
      session.scans.push_back(readPly(fs::path(real_pair) / (std::string(name) + ".ply")));
      FloorHeightConfig any_contrast;
      any_contrast.min_floor_contrast = 0.0;
      const std::optional<FloorHeight> found = floorHeightFromScans(session);
      const std::optional<FloorHeight> seen = floorHeightFromScans(session, any_contrast);
      if (seen)
        std::fprintf(csv, "real,lidar,0,%s,,%.4f,,%d,%d,%.2f,%d\n", name, seen->frame_height_m,
                     seen->floor_points, seen->keyframes, seen->contrast, found ? 1 : 0);
      else
        std::fprintf(csv, "real,lidar,0,%s,,,,0,0,,0\n", name);
    }
  std::fclose(csv);
  return 0;
}
