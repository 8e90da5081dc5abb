// Growing an atlas one session at a time (mm4mm add): the same atlas as merging all at once,
// unconnected sessions placed once a bridge arrives, duplicates and corrupt atlases refused, and
// an add killed at any moment leaves the old atlas or the new one.

#include "mm4mm/atlas/add_session.hpp"

#include <fcntl.h>
#include <grp.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <thread>

#include "calibrated_sessions.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/graph/session_graph.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/g2o_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

// The small corridor preset: s0-s1 and s1-s2 overlap, s3 overlaps nothing.
class AddSessionEndToEnd : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ =
        new fs::path(fs::temp_directory_path() / ("mm4mm_add_test_" + std::to_string(::getpid())));
    fs::remove_all(*root_);
    sim::SimulationConfig config =
        loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "corridor_small.yaml");
    config.layout.disjoint_session = true;
    sessions_ = new std::vector<Session>(sim::simulateSessions(config, 4, 5));
    // Written uncalibrated, as recorded; calibrated in memory as the command line does.
    for (const Session& s : *sessions_) writeSession(s, *root_ / "sessions" / s.id);
    calibrate(sessions_);
    all_at_once_ = new MergeResult(mergeSessions(*sessions_, MergeConfig{}));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*root_);
    delete all_at_once_;
    delete sessions_;
    delete root_;
  }

  static std::string readFile(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }

  static fs::path sourceOf(int s) { return *root_ / "sessions" / (*sessions_)[s].id; }

  // An atlas of session `first` alone, as `mm4mm merge` writes it.
  static void mergeOne(int first, const fs::path& atlas) {
    const std::vector<Session> one{(*sessions_)[first]};
    const MergeResult merged = mergeSessions(one, MergeConfig{});
    writeAtlas(atlas, one, {sourceOf(first)}, merged, buildAtlasOutputs(one, merged, outputs()));
  }

  // What `mm4mm add` does: load, add, rewrite.
  static MergeResult addTo(const fs::path& atlas_dir, int s) {
    Atlas atlas = loadAtlas(atlas_dir);
    calibrate(&atlas.sessions);
    MergeResult result = addSessionToAtlas(atlas, (*sessions_)[s], MergeConfig{});
    std::vector<fs::path> sources;
    for (const AtlasSessionEntry& entry : atlas.manifest.sessions) sources.push_back(entry.source);
    sources.push_back(sourceOf(s));
    atlas.sessions.push_back((*sessions_)[s]);
    writeAtlas(atlas_dir, atlas.sessions, sources, result,
               buildAtlasOutputs(atlas.sessions, result, outputs()));
    return result;
  }

  // Runs the command line on `args` (output discarded) once to the end, then again `attempts`
  // times, each killed (SIGKILL) at a moment drawn from `seed` in its own attempts-th of the
  // interval from `from` to `from + span` times that first run: every stage of the command, and
  // past its end. `restore` puts the state back before each run, `check(attempt)` examines it
  // after each kill.
  template <typename Restore, typename Check>
  static void killAtRandom(std::vector<std::string> args, int attempts, double span, unsigned seed,
                           Restore restore, Check check, double from = 0.0) {
    // Everything a forked child touches is made before the fork: it only calls exec or syscalls.
    std::vector<char*> argv{const_cast<char*>(MM4MM_CLI_PATH)};
    for (std::string& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    const auto spawn = [&argv]() {
      const pid_t child = ::fork();
      if (child == 0) {
        const int devnull = ::open("/dev/null", O_WRONLY);
        ::dup2(devnull, 1), ::dup2(devnull, 2);
        ::execv(MM4MM_CLI_PATH, argv.data());
        ::_exit(127);
      }
      return child;
    };
    restore();
    const auto start = std::chrono::steady_clock::now();
    int status = 0;
    ::waitpid(spawn(), &status, 0);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    const double full_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::mt19937 random(seed);
    std::uniform_real_distribution<double> within(0.0, 1.0);
    for (int attempt = 0; attempt < attempts; ++attempt) {
      restore();
      const pid_t child = spawn();
      std::this_thread::sleep_for(std::chrono::duration<double>(
          full_s * (from + span * (attempt + within(random)) / attempts)));
      ::kill(child, SIGKILL);
      ::waitpid(child, &status, 0);
      check(attempt);
    }
  }

  static AtlasOutputConfig outputs() {
    AtlasOutputConfig config;
    config.octomap.resolution_m = 0.2;  // small files, quick writes
    return config;
  }

  // The manifest's frame of each session against the all-at-once merge's.
  static void expectSameFramesAsAllAtOnce(const fs::path& atlas_dir) {
    const AtlasManifest manifest = readAtlasManifest(atlas_dir);
    ASSERT_EQ(manifest.sessions.size(), sessions_->size());
    for (const AtlasSessionEntry& entry : manifest.sessions) {
      const int s = std::stoi(entry.id.substr(1));
      EXPECT_EQ(entry.connected, static_cast<bool>(all_at_once_->solution.connected[s]))
          << entry.id;
      if (!entry.connected) continue;
      const Eigen::Isometry3d delta =
          all_at_once_->solution.T_atlas_session[s].inverse() * entry.T_atlas_session;
      EXPECT_LT(delta.translation().norm(), 0.02) << entry.id;
      EXPECT_LT(rotationAngle(delta.linear()) * 180.0 / M_PI, 0.05) << entry.id;
    }
  }

  static fs::path* root_;
  static std::vector<Session>* sessions_;
  static MergeResult* all_at_once_;
};
fs::path* AddSessionEndToEnd::root_ = nullptr;
std::vector<Session>* AddSessionEndToEnd::sessions_ = nullptr;
MergeResult* AddSessionEndToEnd::all_at_once_ = nullptr;

TEST_F(AddSessionEndToEnd, AddingOneByOneGivesTheAtlasOfMergingAllAtOnce) {
  ASSERT_TRUE(all_at_once_->solution.connected[1] && all_at_once_->solution.connected[2]);
  ASSERT_FALSE(all_at_once_->solution.connected[3]);
  const fs::path atlas = *root_ / "one_by_one";
  mergeOne(0, atlas);
  for (int s = 1; s < 4; ++s) {
    const MergeResult result = addTo(atlas, s);
    // s1 and s2 are placed by the atlas map: no session-by-session matching. s3 overlaps no one:
    // the atlas map refuses it, and then each of the three placed sessions gets its pair matched
    // as merge matches one (the field, then the joint stage), once each.
    if (s < 3)
      EXPECT_LE(result.magnetic_matches, 2) << "add of s" << s << " matched session by session";
    else
      EXPECT_EQ(result.magnetic_matches, 4) << "the refused s3: the atlas map, then s0, s1, s2";
  }
  expectSameFramesAsAllAtOnce(atlas);
  // The stored graph carries the kept edges of every add, the report the pairs of every add.
  const Atlas loaded = loadAtlas(atlas);
  EXPECT_GT(loaded.edges.size(), 4u);
  std::set<std::string> accepted;
  for (const PairResult& pair : loaded.pairs)
    if (pair.accepted)
      accepted.insert(loaded.sessions[pair.a].id + "+" + loaded.sessions[pair.b].id);
  EXPECT_EQ(accepted, (std::set<std::string>{"s0+s1", "s1+s2"}));

  // What eval reads: the same poses, frames and pairs, without readings, scans, edges or map.
  const Atlas poses = loadAtlas(atlas, SessionParts::kPoses);
  ASSERT_EQ(poses.sessions.size(), loaded.sessions.size());
  EXPECT_EQ(poses.connected, loaded.connected);
  EXPECT_EQ(poses.frame_session, loaded.frame_session);
  EXPECT_EQ(poses.pairs.size(), loaded.pairs.size());
  EXPECT_TRUE(poses.edges.empty());
  EXPECT_EQ(poses.fused_magnetic_map.coveredCells(), 0u);
  EXPECT_GT(loaded.fused_magnetic_map.coveredCells(), 0u);
  for (std::size_t s = 0; s < poses.sessions.size(); ++s) {
    const Session& light = poses.sessions[s];
    const Session& full = loaded.sessions[s];
    EXPECT_EQ(light.id, full.id);
    EXPECT_TRUE(light.magnetometer.empty() && !light.hasScans()) << light.id;
    EXPECT_FALSE(full.magnetometer.empty() || !full.hasScans()) << full.id;
    ASSERT_EQ(light.keyframes.size(), full.keyframes.size());
    ASSERT_TRUE(light.ground_truth.has_value());
    EXPECT_EQ(light.ground_truth->size(), full.ground_truth->size());
    ASSERT_EQ(poses.T_atlas_keyframe[s].size(), loaded.T_atlas_keyframe[s].size());
    for (std::size_t k = 0; k < light.keyframes.size(); ++k) {
      EXPECT_TRUE(light.keyframes[k].T_frame_body.isApprox(full.keyframes[k].T_frame_body, 0.0));
      EXPECT_TRUE(poses.T_atlas_keyframe[s][k].isApprox(loaded.T_atlas_keyframe[s][k], 0.0));
    }
  }
}

TEST_F(AddSessionEndToEnd, AnUnconnectedSessionIsPlacedWhenABridgeArrives) {
  const fs::path atlas = *root_ / "bridge";
  mergeOne(0, atlas);
  const MergeResult lone = addTo(atlas, 2);  // s2 overlaps only s1, which is not there yet
  EXPECT_FALSE(lone.solution.connected[1]);
  const MergeResult bridged = addTo(atlas, 1);
  EXPECT_TRUE(bridged.solution.connected[1]) << "s2 stayed unconnected";
  EXPECT_TRUE(bridged.solution.connected[2]) << "the bridge s1 was not placed";
  addTo(atlas, 3);
  expectSameFramesAsAllAtOnce(atlas);
}

// The atlas map reads the field at the height above the floor its placed sessions share, not at
// its z in the atlas frame, which an odometry's tilt carried along a chain of sessions moves: a
// new session at the placed sessions' height is matched against it, one at another height only
// pair by pair.
TEST_F(AddSessionEndToEnd, ANewSessionMeetsTheAtlasMapAtItsHeightAboveTheFloor) {
  const fs::path atlas_dir = *root_ / "heights";
  mergeOne(0, atlas_dir);
  Atlas atlas = loadAtlas(atlas_dir);
  calibrate(&atlas.sessions);
  ASSERT_TRUE(atlas.sessions[0].rig.frame_height_above_floor_m.has_value());
  atlas.fused_magnetic_map.height_m += 0.5;  // as a tilted chain lifts it in the atlas frame
  std::vector<std::string> lines;
  const auto log = [&](const std::string& line) { lines.push_back(line); };
  const auto said = [&](const std::string& text) {
    return std::any_of(lines.begin(), lines.end(), [&](const std::string& line) {
      return line.find(text) != std::string::npos;
    });
  };
  const MergeResult level = addSessionToAtlas(atlas, (*sessions_)[1], MergeConfig{}, log);
  EXPECT_TRUE(said("matched s1 against the atlas map")) << "s1 was matched pair by pair";
  EXPECT_FALSE(said("not matched against it"));
  EXPECT_TRUE(level.solution.connected[1]);

  lines.clear();
  Session raised = (*sessions_)[1];
  raised.rig.frame_height_above_floor_m = 0.5;
  addSessionToAtlas(atlas, raised, MergeConfig{}, log);
  EXPECT_TRUE(
      said("s1's magnetometers are +0.50 m above the atlas map's height: not matched "
           "against it, only pair by pair"));
  EXPECT_FALSE(said("matched s1 against the atlas map"));
}

TEST_F(AddSessionEndToEnd, ASessionAlreadyInTheAtlasIsRefused) {
  const fs::path atlas_dir = *root_ / "duplicates";
  mergeOne(0, atlas_dir);
  const Atlas atlas = loadAtlas(atlas_dir);
  try {
    addSessionToAtlas(atlas, (*sessions_)[0], MergeConfig{});
    FAIL() << "the same id was added twice";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'s0' is already in the atlas"), std::string::npos)
        << e.what();
  }
  Session renamed = (*sessions_)[0];
  renamed.id = "s0_again";
  try {
    addSessionToAtlas(atlas, renamed, MergeConfig{});
    FAIL() << "the same recording was added under another id";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("same recording as 's0'"), std::string::npos) << e.what();
  }
}

TEST_F(AddSessionEndToEnd, ACorruptOrHalfWrittenAtlasIsRefused) {
  const fs::path atlas = *root_ / "corrupt";
  mergeOne(0, atlas);
  ASSERT_NO_THROW(readAtlasManifest(atlas));
  const auto expectRefusal = [&](const std::string& expected) {
    try {
      loadAtlas(atlas);
      FAIL() << "a damaged atlas was loaded (expected: " << expected << ")";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  {  // one byte changed in the middle of a file
    std::fstream file(atlas / "merged.ply", std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(400);
    file.put('#');
  }
  expectRefusal("merged.ply does not match its checksum");
  fs::remove(atlas / "merged.ply");
  expectRefusal("lists merged.ply, which is missing");
  mergeOne(0, atlas);
  const std::string manifest = readFile(atlas / "atlas.yaml");
  // Cut at a line end inside 'files': every file still listed matches, the last one is unlisted.
  std::ofstream(atlas / "atlas.yaml")
      << manifest.substr(0, manifest.rfind('\n', manifest.size() - 2) + 1);
  expectRefusal("is not listed in 'files'");
  std::ofstream(atlas / "atlas.yaml") << manifest.substr(0, manifest.size() / 2);
  expectRefusal("atlas.yaml");
  // Found by fuzz/fuzz_atlas.cpp: a scalar where a map belongs made yaml-cpp throw past the reader.
  // The manifest of before stored configs (version 2) kept its OctoMap resolution in 'settings'.
  std::string scalar_settings = manifest;
  scalar_settings.replace(scalar_settings.find("version: 3\n"), 11, "version: 2\nsettings: 3\n");
  std::ofstream(atlas / "atlas.yaml") << scalar_settings;
  expectRefusal("settings: expected a map holding 'octomap_resolution_m'");
  fs::remove(atlas / "atlas.yaml");
  expectRefusal("not an atlas directory");
}

// An atlas whose files point elsewhere is refused before anything outside it is read: a data file
// replaced by a link to an identical copy outside (its checksum still matches), the atlas
// directory given through a link, a report too large to parse whole, a manifest nested past
// yaml-cpp's depth guard.
TEST_F(AddSessionEndToEnd, AHostileAtlasIsRefusedBeforeAnythingOutsideItIsRead) {
  const fs::path atlas = *root_ / "hostile";
  const fs::path outside = *root_ / "outside";
  mergeOne(0, atlas);
  ASSERT_NO_THROW(loadAtlas(atlas));
  const auto expectRefusal = [&](const fs::path& dir, const std::string& expected) {
    try {
      loadAtlas(dir);
      FAIL() << "a hostile atlas was loaded (expected: " << expected << ")";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  fs::create_directories(outside);
  fs::rename(atlas / "merged.ply", outside / "merged.ply");
  fs::create_symlink(outside / "merged.ply", atlas / "merged.ply");
  expectRefusal(atlas, "merged.ply is a symbolic link (to " + (outside / "merged.ply").string());
  fs::remove(atlas / "merged.ply");
  fs::rename(outside / "merged.ply", atlas / "merged.ply");
  ASSERT_NO_THROW(loadAtlas(atlas));

  fs::rename(atlas / "trajectories", outside / "trajectories");
  fs::create_directory_symlink(outside / "trajectories", atlas / "trajectories");
  expectRefusal(atlas, "trajectories is a symbolic link");
  fs::remove(atlas / "trajectories");
  fs::rename(outside / "trajectories", atlas / "trajectories");

  const fs::path link = *root_ / "hostile_link";
  fs::create_directory_symlink(atlas, link);
  expectRefusal(link, "is a symbolic link (to " + atlas.string() + "): give the atlas directory");
  expectRefusal(link.string() + "/", "is a symbolic link");
  EXPECT_THROW(checkAtlasTarget(link, {}), std::invalid_argument);  // merge --out LINK

  const std::string report = readFile(atlas / "report.json");
  fs::resize_file(atlas / "report.json", std::uintmax_t{1} << 30);  // sparse: no disk used
  expectRefusal(atlas, "report.json is 1024 MiB; an atlas's report.json is read whole, up to 256");
  std::ofstream(atlas / "report.json", std::ios::binary | std::ios::trunc) << report;
  ASSERT_NO_THROW(loadAtlas(atlas));

  const std::string manifest = readFile(atlas / "atlas.yaml");
  for (const std::string& elsewhere : {"../outside/merged.ply", "/etc/hostname"}) {
    std::string pointing = manifest;
    pointing.replace(pointing.find("merged.ply:"), 10, elsewhere);
    std::ofstream(atlas / "atlas.yaml", std::ios::trunc) << pointing;
    expectRefusal(atlas, "'" + elsewhere + "' is not a file of the atlas");
  }
  std::ofstream(atlas / "atlas.yaml") << "version: " << std::string(100000, '[') << "\n";
  expectRefusal(atlas, "not valid YAML");
}

TEST_F(AddSessionEndToEnd, AKilledAddLeavesTheOldAtlasOrTheNewOne) {
  const fs::path atlas = *root_ / "killed";
  const fs::path before = *root_ / "killed_before";
  mergeOne(0, atlas);
  fs::copy(atlas, before, fs::copy_options::recursive);
  int old_seen = 0, new_seen = 0;
  // One kill in each tenth of 1.3 times an add's run: every stage of the add, and past its end,
  // where the new atlas must be found whole.
  killAtRandom(
      {"add", atlas.string(), sourceOf(1).string()}, 10, 1.3, 42,
      [&] {
        fs::remove_all(atlas);
        fs::copy(before, atlas, fs::copy_options::recursive);
      },
      [&](int attempt) {
        AtlasManifest manifest;
        ASSERT_NO_THROW(manifest = readAtlasManifest(atlas)) << "attempt " << attempt;
        ASSERT_TRUE(manifest.sessions.size() == 1 || manifest.sessions.size() == 2);
        (manifest.sessions.size() == 1 ? old_seen : new_seen)++;
        ASSERT_NO_THROW(loadAtlas(atlas)) << "attempt " << attempt;
      });
  EXPECT_GT(old_seen, 0);  // some kills landed before the swap
  std::cout << "killed adds: " << old_seen << " left the old atlas, " << new_seen << " the new\n";
  // No scratch directory of a killed add survives the next write.
  mergeOne(0, atlas);
  for (const auto& entry : fs::directory_iterator(*root_))
    EXPECT_EQ(entry.path().filename().string().find("killed.partial"), std::string::npos)
        << entry.path();
}

// `mm4mm export octomap` swaps a new atlas in as add does: killed at any moment, the atlas loads
// with every checksum, without octomap.bt (as add left it) or with the whole new one.
TEST_F(AddSessionEndToEnd, AKilledOctoMapExportLeavesTheAtlasWithoutItOrWithAllOfIt) {
  const fs::path atlas = *root_ / "killed_export";
  const fs::path before = *root_ / "killed_export_before";
  const std::vector<Session> one{(*sessions_)[0]};
  const MergeResult merged = mergeSessions(one, MergeConfig{});
  writeAtlas(atlas, one, {sourceOf(0)}, merged,
             buildAtlasOutputs(one, merged, outputs(), OctoMapBuild::kLeaveOut));
  ASSERT_FALSE(fs::exists(atlas / "octomap.bt"));
  fs::copy(atlas, before, fs::copy_options::recursive);
  const auto restore = [&] {
    fs::remove_all(atlas);
    fs::copy(before, atlas, fs::copy_options::recursive);
  };
  restore();
  ASSERT_EQ(std::system((std::string(MM4MM_CLI_PATH) + " export octomap " + atlas.string() +
                         " >/dev/null 2>&1")
                            .c_str()),
            0);
  const std::string exported = readFile(atlas / "octomap.bt");
  ASSERT_FALSE(exported.empty());
  int without = 0, with = 0;
  const auto check = [&](int attempt) {
    ASSERT_NO_THROW(loadAtlas(atlas)) << "attempt " << attempt;
    if (fs::exists(atlas / "octomap.bt")) {
      EXPECT_EQ(readFile(atlas / "octomap.bt"), exported) << "attempt " << attempt;
      ++with;
    } else {
      ++without;
    }
  };
  // Six kills in the sixths of an export's run, then two from 3 to 4 times that long, after the
  // swap even on a machine loaded by the tests running beside this one (at 1.6 times, every kill
  // of one such run still landed before it).
  killAtRandom({"export", "octomap", atlas.string()}, 6, 1.0, 7, restore, check);
  killAtRandom({"export", "octomap", atlas.string()}, 2, 1.0, 8, restore, check, 3.0);
  EXPECT_GT(without, 0);
  EXPECT_GT(with, 0);
  std::cout << "killed exports: " << without << " left the atlas without its OctoMap, " << with
            << " with it\n";
}

// Runs the command line on `args` with its output in `log`; `prepare()` runs in the child just
// before exec (syscalls only: limits, identity). Returns waitpid's status.
template <typename Prepare>
int runCliWith(std::vector<std::string> args, const fs::path& log, Prepare prepare) {
  // Everything a forked child touches is made before the fork.
  std::vector<char*> argv{const_cast<char*>(MM4MM_CLI_PATH)};
  for (std::string& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const pid_t child = ::fork();
  if (child == 0) {
    const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(out, 1), ::dup2(out, 2);
    prepare();
    ::execv(MM4MM_CLI_PATH, argv.data());
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  return status;
}

// Every regular file under `dir` (relative path) with its content.
std::map<std::string, std::string> filesUnder(const fs::path& dir) {
  std::map<std::string, std::string> content;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    if (entry.is_regular_file()) {
      std::ifstream in(entry.path(), std::ios::binary);
      content[fs::relative(entry.path(), dir).string()] =
          std::string(std::istreambuf_iterator<char>(in), {});
    }
  return content;
}

// No writer's scratch directory (`<name>.partial<pid>`) left in `dir`.
void expectNoScratch(const fs::path& dir, const std::string& name) {
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(name + ".partial"), std::string::npos)
        << entry.path();
}

// A write that fails part way (the file size limit, `ulimit -f`, reached by the first large
// output): one message naming the file and a non-zero exit, not a kill; no atlas where merge was
// to write one; after add, the previous atlas byte for byte; no scratch left behind.
TEST_F(AddSessionEndToEnd, AWriteThatFailsLeavesThePreviousStateAndNamesTheFile) {
  const fs::path atlas = *root_ / "limited";
  const fs::path log = *root_ / "limited.log";
  constexpr rlim_t kLimitBytes = 256 * 1024;
  const auto runLimited = [&](std::vector<std::string> args) {
    return runCliWith(std::move(args), log, [] {
      const rlimit limit{kLimitBytes, kLimitBytes};
      ::setrlimit(RLIMIT_FSIZE, &limit);
    });
  };

  int status = runLimited({"merge", sourceOf(0).string(), "--out", atlas.string()});
  EXPECT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 5);
  std::string said = readFile(log);
  EXPECT_NE(said.find("mm4mm: error: cannot write "), std::string::npos) << said;
  EXPECT_NE(said.find("File too large"), std::string::npos) << said;
  EXPECT_NE(said.find(atlas.string() + ".partial"), std::string::npos) << said;
  EXPECT_FALSE(fs::exists(atlas));
  expectNoScratch(*root_, "limited");

  mergeOne(0, atlas);
  const auto before = filesUnder(atlas);
  status = runLimited({"add", atlas.string(), sourceOf(1).string()});
  EXPECT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 5);
  said = readFile(log);
  EXPECT_NE(said.find("File too large"), std::string::npos) << said;
  EXPECT_TRUE(filesUnder(atlas) == before) << "the previous atlas changed";
  EXPECT_NO_THROW(loadAtlas(atlas));
  expectNoScratch(*root_, "limited");
}

// A small tmpfs mounted for as long as it lives: a file system that fills up.
class SmallFileSystem {
 public:
  SmallFileSystem(const fs::path& at, std::uintmax_t bytes) : at_(at) {
    fs::create_directories(at);
    const std::string options = "size=" + std::to_string(bytes);
    mounted_ = ::mount("tmpfs", at.c_str(), "tmpfs", 0, options.c_str()) == 0;
    if (!mounted_) error_ = std::strerror(errno);
  }
  ~SmallFileSystem() {
    if (mounted_) ::umount2(at_.c_str(), MNT_DETACH);
  }
  SmallFileSystem(const SmallFileSystem&) = delete;
  SmallFileSystem& operator=(const SmallFileSystem&) = delete;
  bool mounted() const { return mounted_; }
  const std::string& error() const { return error_; }

 private:
  fs::path at_;
  bool mounted_ = false;
  std::string error_;
};

// The file system fills up part way through the write (ENOSPC): merge leaves no atlas, add the
// previous one byte for byte, each says which file and why, and no scratch is left to hold the
// space. Mounting needs root, which the suite has in CI.
TEST_F(AddSessionEndToEnd, AFullFileSystemLeavesThePreviousStateAndNamesTheFile) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a small tmpfs (a full file system)";
  const fs::path sized = *root_ / "sized";
  mergeOne(0, sized);
  std::uintmax_t bytes = 0;
  for (const auto& [name, content] : filesUnder(sized)) bytes += content.size();
  const fs::path log = *root_ / "full.log";
  // Runs the command line, which should fail to write `atlas` for want of space, and say so.
  const auto runOutOfSpace = [&](std::vector<std::string> args, const fs::path& atlas) {
    const int status = runCliWith(std::move(args), log, [] {});
    EXPECT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
    EXPECT_EQ(WEXITSTATUS(status), 5);
    const std::string said = readFile(log);
    EXPECT_NE(said.find("mm4mm: error: cannot write " + atlas.string() + ".partial"),
              std::string::npos)
        << said;
    EXPECT_NE(said.find("No space left on device"), std::string::npos) << said;
  };

  {  // Room for half of a one-session atlas.
    const fs::path mount = *root_ / "full_merge";
    const SmallFileSystem full(mount, bytes / 2);
    ASSERT_TRUE(full.mounted()) << "mount tmpfs: " << full.error();
    const fs::path atlas = mount / "atlas";
    runOutOfSpace({"merge", sourceOf(0).string(), "--out", atlas.string()}, atlas);
    EXPECT_FALSE(fs::exists(atlas));
    expectNoScratch(mount, "atlas");
  }
  {  // Room for the one-session atlas, not for it and a two-session one staged beside it.
    const fs::path mount = *root_ / "full_add";
    const SmallFileSystem full(mount, bytes * 3 / 2);
    ASSERT_TRUE(full.mounted()) << "mount tmpfs: " << full.error();
    const fs::path atlas = mount / "atlas";
    mergeOne(0, atlas);
    const auto before = filesUnder(atlas);
    runOutOfSpace({"add", atlas.string(), sourceOf(1).string()}, atlas);
    EXPECT_TRUE(filesUnder(atlas) == before) << "the previous atlas changed";
    EXPECT_NO_THROW(loadAtlas(atlas));
    expectNoScratch(mount, "atlas");
  }
}

// A directory the user may not write: merge, add and export octomap say so at once (before any
// matching), exit 5, and leave everything as it was. Run as `nobody`; root writes anyway.
TEST_F(AddSessionEndToEnd, AnUnwritableDirectoryIsSaidBeforeAnyWork) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to run the command line as another user";
  const fs::path parent = *root_ / "not_yours";
  fs::create_directories(parent);
  fs::permissions(parent, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                              fs::perms::others_read | fs::perms::others_exec);
  const fs::path atlas = parent / "atlas";
  mergeOne(0, atlas);
  // As `mm4mm merge` run by the owner leaves it: a lock file anyone can open to lock.
  std::ofstream(parent / "atlas.lock").close();
  const auto before = filesUnder(atlas);
  const fs::path log = *root_ / "not_yours.log";
  const auto runAsNobody = [&](std::vector<std::string> args) {
    const int status = runCliWith(std::move(args), log, [] {
      constexpr uid_t kNobody = 65534;
      if (::setgroups(0, nullptr) != 0 || ::setgid(kNobody) != 0 || ::setuid(kNobody) != 0)
        ::_exit(126);
    });
    EXPECT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
    return WEXITSTATUS(status);
  };

  EXPECT_EQ(runAsNobody({"add", atlas.string(), sourceOf(1).string()}), 5);
  std::string said = readFile(log);
  EXPECT_NE(said.find("mm4mm: error: cannot write in " + parent.string()), std::string::npos)
      << said;
  EXPECT_NE(said.find("Permission denied"), std::string::npos) << said;
  EXPECT_EQ(said.find("matched"), std::string::npos) << "said after matching:\n" << said;

  EXPECT_EQ(runAsNobody({"export", "octomap", atlas.string()}), 5);
  said = readFile(log);
  EXPECT_NE(said.find("mm4mm: error: cannot write in " + parent.string()), std::string::npos)
      << said;

  const fs::path other = parent / "other";
  EXPECT_EQ(runAsNobody({"merge", sourceOf(0).string(), "--out", other.string()}), 5);
  said = readFile(log);
  EXPECT_NE(said.find("cannot create the atlas's lock file " + other.string() + ".lock"),
            std::string::npos)
      << said;
  EXPECT_NE(said.find("Permission denied"), std::string::npos) << said;
  EXPECT_FALSE(fs::exists(other));

  EXPECT_TRUE(filesUnder(atlas) == before) << "the atlas changed";
  expectNoScratch(parent, "atlas");
}

TEST_F(AddSessionEndToEnd, OneWriterAtATime) {
  const fs::path atlas = *root_ / "locked";
  mergeOne(0, atlas);
  const std::string manifest_before = readFile(atlas / "atlas.yaml");
  // Everything a forked child touches is made before the fork: it only calls exec or syscalls.
  const std::string atlas_path = atlas.string();
  const std::string source = sourceOf(1).string();
  const std::string stderr_path = (*root_ / "locked_add.err").string();
  const std::string lock_path = atlas_path + ".lock";
  const auto addExitCode = [&]() {
    const pid_t child = ::fork();
    if (child == 0) {
      const int err = ::open(stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      const int devnull = ::open("/dev/null", O_WRONLY);
      ::dup2(devnull, 1), ::dup2(err, 2);
      ::execl(MM4MM_CLI_PATH, MM4MM_CLI_PATH, "add", atlas_path.c_str(), source.c_str(), nullptr);
      ::_exit(127);
    }
    int status = 0;
    ::waitpid(child, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  {
    const AtlasWriteLock held(atlas);
    EXPECT_THROW(AtlasWriteLock second(atlas), AtlasBusy);  // flock: per open, not per process
    EXPECT_EQ(addExitCode(), 4);
    EXPECT_NE(readFile(stderr_path).find("another mm4mm process is writing this atlas"),
              std::string::npos)
        << readFile(stderr_path);
    EXPECT_EQ(readFile(atlas / "atlas.yaml"), manifest_before);
  }
  // A writer killed while holding the lock does not keep it. The child says through a pipe when
  // it holds the lock.
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t holder = ::fork();
  if (holder == 0) {
    const int fd = ::open(lock_path.c_str(), O_RDONLY);
    if (fd < 0 || ::flock(fd, LOCK_EX) != 0) ::_exit(1);
    const char byte = 1;
    if (::write(ready[1], &byte, 1) != 1) ::_exit(1);
    ::pause();
    ::_exit(0);
  }
  char byte = 0;
  ASSERT_EQ(::read(ready[0], &byte, 1), 1);
  ::close(ready[0]), ::close(ready[1]);
  EXPECT_THROW(AtlasWriteLock while_held(atlas), AtlasBusy);
  ::kill(holder, SIGKILL);
  ::waitpid(holder, nullptr, 0);
  EXPECT_NO_THROW(AtlasWriteLock after_kill(atlas));
  EXPECT_EQ(addExitCode(), 0) << readFile(stderr_path);
  EXPECT_EQ(readAtlasManifest(atlas).sessions.size(), 2u);
  // A directory that is no atlas is refused before a lock file is made beside it.
  const fs::path not_atlas = *root_ / "not_an_atlas";
  fs::create_directories(not_atlas);
  EXPECT_EQ(std::system((std::string(MM4MM_CLI_PATH) + " add " + not_atlas.string() + " " + source +
                         " 2>/dev/null >/dev/null")
                            .c_str()) >>
                8,
            2);
  EXPECT_FALSE(fs::exists(not_atlas.string() + ".lock"));
}

// As merge_test's GeometryProposesAndTheFieldDecides, through `add`: one magnetometer in a
// warehouse (tuning seed 1, sessions 1 and 2). Counting one sample per m², the field alone calls
// the pair ambiguous, so the atlas map does not place the added session; matched with the placed
// session as merge matches a pair, the walls propose shifts one aisle apart and the field decides.
// Without the joint stage the add leaves the session unconnected.
TEST(AddSessionJointEndToEnd, WhereTheAtlasMapRefusesGeometryProposesAndTheFieldDecides) {
  sim::SimulationConfig config;  // warehouse, one IMU magnetometer, realistic sensors
  const std::vector<Session> all = calibrated(sim::simulateSessions(config, 3, 1));
  const fs::path root =
      fs::temp_directory_path() / ("mm4mm_add_joint_test_" + std::to_string(::getpid()));
  fs::remove_all(root);
  MergeConfig per_m2;
  per_m2.matcher.single_track.area_per_sample_m2 = 1.0;
  per_m2.matcher.single_track.min_overlap_m2 = 4.0;
  per_m2.matcher.single_track.min_z = 2.5;
  per_m2.matcher.single_track.min_r = 0.825;
  AtlasOutputConfig outputs;
  outputs.octomap.resolution_m = 0.2;
  const std::vector<Session> first{all[1]};
  writeSession(all[1], root / "s1");
  const MergeResult merged = mergeSessions(first, per_m2);
  writeAtlas(root / "atlas", first, {root / "s1"}, merged,
             buildAtlasOutputs(first, merged, outputs));
  Atlas atlas = loadAtlas(root / "atlas");
  calibrate(&atlas.sessions);

  const MergeResult added = addSessionToAtlas(atlas, all[2], per_m2);
  ASSERT_EQ(added.solution.connected.size(), 2u);
  EXPECT_TRUE(added.solution.connected[1]) << "the added session was not placed";
  const auto joint = std::find_if(added.pairs.begin(), added.pairs.end(),
                                  [](const PairResult& pair) { return pair.joint; });
  ASSERT_NE(joint, added.pairs.end()) << "no pair was placed by the joint stage";
  EXPECT_TRUE(joint->accepted);
  if (added.solution.connected[1]) {
    const OverlapError error = overlapError(all[1], all[2], added.solution.T_atlas_keyframe[0],
                                            added.solution.T_atlas_keyframe[1]);
    EXPECT_TRUE(error.aligned()) << error.median_translation_m << " m, "
                                 << error.median_rotation_deg << " deg";
  }

  MergeConfig field_alone = per_m2;
  field_alone.joint.enabled = false;
  EXPECT_FALSE(addSessionToAtlas(atlas, all[2], field_alone).solution.connected[1]);
  fs::remove_all(root);
}

TEST(StoredGraph, InterSessionEdgesReadBackFromTheMultiSessionG2o) {
  sim::SimulationConfig config =
      loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "corridor_small.yaml");
  const std::vector<Session> sessions = sim::simulateSessions(config, 2, 3);
  const std::vector<SessionGraph> graphs{buildSessionGraph(sessions[0]),
                                         buildSessionGraph(sessions[1])};
  std::vector<InterSessionEdge> edges(2);
  edges[0] = {0,
              3,
              1,
              7,
              Eigen::Isometry3d(Eigen::Translation3d(0.5, -0.25, 0.125)),
              Eigen::Matrix<double, 6, 6>::Identity() * 40.0};
  edges[1] = {1,
              0,
              0,
              12,
              Eigen::Isometry3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())),
              Eigen::Matrix<double, 6, 6>::Identity() * 2.5};
  const fs::path file = fs::temp_directory_path() / ("mm4mm_edges_" + std::to_string(::getpid()));
  writeMultiSessionGraphG2o(graphs, edges, file);
  const StoredInterSessionEdges stored = readInterSessionEdgesG2o(file);

  // Each graph made as it is written (what an atlas's writer does) gives the same file.
  const fs::path lazy = file.string() + "_lazy";
  std::vector<std::size_t> made;
  const auto graph_at = [&](std::size_t g) {
    made.push_back(g);
    std::vector<Eigen::Isometry3d> poses;
    for (const StampedPose& k : sessions[g].keyframes) poses.push_back(k.T_frame_body);
    return buildSessionGraphAt(sessions[g], poses);
  };
  writeMultiSessionGraphG2o(2, graph_at, edges, lazy);
  EXPECT_EQ(made, (std::vector<std::size_t>{0, 1}));
  std::ifstream a(file), b(lazy);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(a), {}),
            std::string(std::istreambuf_iterator<char>(b), {}));
  fs::remove(file);
  fs::remove(lazy);
  // An edge to a keyframe the graph lacks is refused, and no file is left behind.
  std::vector<InterSessionEdge> bad = edges;
  bad[1].keyframe_a = static_cast<int>(sessions[1].keyframes.size());
  EXPECT_THROW(writeMultiSessionGraphG2o(2, graph_at, bad, lazy), std::invalid_argument);
  for (const auto& entry : fs::directory_iterator(lazy.parent_path()))
    EXPECT_EQ(entry.path().filename().string().rfind(lazy.filename().string(), 0),
              std::string::npos)
        << entry.path();
  ASSERT_EQ(stored.session_ids, (std::vector<std::string>{sessions[0].id, sessions[1].id}));
  ASSERT_EQ(stored.edges.size(), 2u);
  for (std::size_t e = 0; e < 2; ++e) {
    EXPECT_EQ(stored.edges[e].session_a, edges[e].session_a);
    EXPECT_EQ(stored.edges[e].keyframe_a, edges[e].keyframe_a);
    EXPECT_EQ(stored.edges[e].session_b, edges[e].session_b);
    EXPECT_EQ(stored.edges[e].keyframe_b, edges[e].keyframe_b);
    EXPECT_TRUE(stored.edges[e].T_a_b.isApprox(edges[e].T_a_b, 1e-12));
    EXPECT_TRUE(stored.edges[e].information.isApprox(edges[e].information, 1e-12));
  }
}

}  // namespace
}  // namespace mm4mm
