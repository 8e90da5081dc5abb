// The config surface: one field list (src/io/config_fields.hpp) read and written as YAML, the
// reader's errors, and the shipped configs/mm4mm.yaml.

#include "mm4mm/io/config_io.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "io/config_fields.hpp"
#include "mm4mm/io/input_error.hpp"

namespace {

namespace fs = std::filesystem;
using namespace mm4mm;

template <typename T>
struct IsVector : std::false_type {};
template <typename T>
struct IsVector<std::vector<T>> : std::true_type {};
template <typename T>
constexpr bool kIsStruct = std::is_class_v<T> && !IsVector<T>::value;

PipelineConfig parse(const std::string& text) {
  return parsePipelineConfig(text, "test.yaml", {}, nullptr);
}

PipelineConfig parseChecked(const std::string& text) {
  return parsePipelineConfig(text, "test.yaml", {},
                             [](const PipelineConfig& c, std::string* e) { return c.IsValid(e); });
}

// The InputError's message of parsing `text` with the validity check, or "" when it parses.
std::string errorOf(const std::string& text) {
  try {
    parseChecked(text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// Records where each listed member lies in its struct, and checks every nested struct the same
// way: a member left out of config_fields.hpp leaves a hole in the struct's bytes wider than
// padding (any member of 8 bytes or more, and most smaller ones).
struct Layout {
  const char* base;
  std::string path;
  std::vector<std::string>* problems;
  struct Member {
    std::size_t offset, size, align;
    std::string key;
  };
  std::vector<Member> members;

  template <typename T>
  void field(const char* key, T& value) {
    members.push_back({static_cast<std::size_t>(reinterpret_cast<const char*>(&value) - base),
                       sizeof(T), alignof(T), key});
    if constexpr (kIsStruct<T>) check(value, path + key + ".", problems);
  }

  template <typename S>
  static void check(S& s, const std::string& path, std::vector<std::string>* problems) {
    Layout layout{reinterpret_cast<const char*>(&s), path, problems, {}};
    io_detail::visitFields(layout, s);
    std::sort(layout.members.begin(), layout.members.end(),
              [](const Member& a, const Member& b) { return a.offset < b.offset; });
    std::size_t end = 0;
    for (const Member& m : layout.members) {
      if (m.offset < end) problems->push_back(path + m.key + " is listed twice");
      if (m.offset > end && m.offset - end >= m.align)
        problems->push_back(path + ": a member before " + m.key + " is not listed");
      end = std::max(end, m.offset + m.size);
    }
    if (sizeof(S) - end >= alignof(S))
      problems->push_back(path + ": a member after the last listed one is not listed");
  }
};

TEST(ConfigIo, EveryMemberOfEveryStructIsListed) {
  PipelineConfig config;
  std::vector<std::string> problems;
  Layout::check(config, "", &problems);
  EXPECT_TRUE(problems.empty()) << problems.front();
}

std::vector<std::string> linesOf(const std::string& text) {
  std::vector<std::string> lines;
  for (std::size_t begin = 0; begin < text.size();) {
    const std::size_t end = std::min(text.find('\n', begin), text.size());
    lines.push_back(text.substr(begin, end - begin));
    begin = end + 1;
  }
  return lines;
}

// Every field changed from its default: numbers moved, flags flipped, enums to their next name.
struct Perturb {
  template <typename T>
  void field(const char*, T& value) {
    if constexpr (std::is_enum_v<T>) {
      const auto& names = io_detail::enumNames(T{});
      for (std::size_t i = 0; i < names.size(); ++i)
        if (names[i].second == value) {
          value = names[(i + 1) % names.size()].second;
          break;
        }
    } else if constexpr (IsVector<T>::value) {
      for (double& v : value) v = v * 1.5 + 0.125;
      value.push_back(0.0625);
    } else if constexpr (kIsStruct<T>) {
      io_detail::visitFields(*this, value);
    } else if constexpr (std::is_same_v<T, bool>) {
      value = !value;
    } else if constexpr (std::is_floating_point_v<T>) {
      value = value * 1.5 + 0.1;
    } else {
      value += static_cast<T>(std::is_unsigned_v<T> ? 12345678901234567ULL : 7);
    }
  }
};

TEST(ConfigIo, DefaultsDumpAndLoadBackEqual) {
  const std::string dump = pipelineConfigYaml(PipelineConfig{});
  EXPECT_EQ(pipelineConfigYaml(parseChecked(dump)), dump);
  // The dump holds the structs' own names and nesting.
  EXPECT_NE(dump.find("merge:\n  matcher:\n    calibration:\n      enabled: true\n"),
            std::string::npos)
      << dump;
  EXPECT_NE(dump.find("outputs:\n  cloud:\n"), std::string::npos) << dump;
}

TEST(ConfigIo, AConfigWithEveryFieldChangedDumpsAndLoadsBackEqual) {
  PipelineConfig changed;
  Perturb perturb;
  io_detail::visitFields(perturb, changed);
  changed.merge.pair_icp.prior_sigma_yaw_deg = std::numeric_limits<double>::infinity();
  changed.merge.matcher.search.yaw_centre_deg = -17.25;
  const std::string dump = pipelineConfigYaml(changed);
  const PipelineConfig back = parse(dump);
  EXPECT_EQ(pipelineConfigYaml(back), dump);
  // Not the defaults: the two dumps list the same keys in the same order, and every value differs.
  const std::vector<std::string> lines = linesOf(dump);
  const std::vector<std::string> defaults = linesOf(pipelineConfigYaml(PipelineConfig{}));
  ASSERT_EQ(lines.size(), defaults.size());
  int values = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].empty() || lines[i].back() == ':' || lines[i][0] == '#') continue;
    ++values;
    EXPECT_NE(lines[i], defaults[i]) << "unchanged";
  }
  EXPECT_GT(values, 150);
  EXPECT_EQ(back.merge.pair_icp.prior_sigma_yaw_deg, std::numeric_limits<double>::infinity());
  EXPECT_EQ(back.merge.matcher.pso.seed, changed.merge.matcher.pso.seed);
  EXPECT_EQ(back.merge.pair_icp.voxel_sizes_m, changed.merge.pair_icp.voxel_sizes_m);
  EXPECT_EQ(back.outputs.octomap.resolution_m, changed.outputs.octomap.resolution_m);
}

template <typename Enum, typename Get>
void expectEveryNameRoundTrips(Get get, const std::string& key) {
  for (const auto& [name, value] : io_detail::enumNames(Enum{})) {
    PipelineConfig config;
    get(config) = value;
    const std::string dump = pipelineConfigYaml(config);
    EXPECT_NE(dump.find(key + ": " + name + "\n"), std::string::npos) << key << ": " << name;
    PipelineConfig back = parse(dump);
    EXPECT_EQ(get(back), value) << key << ": " << name;
  }
}

TEST(ConfigIo, EveryEnumNameRoundTrips) {
  expectEveryNameRoundTrips<SingleSensorInterpolation>(
      [](PipelineConfig & c) -> auto& { return c.merge.matcher.map.single_sensor_interpolation; },
      "single_sensor_interpolation");
  expectEveryNameRoundTrips<GlobalSearchMethod>(
      [](PipelineConfig & c) -> auto& { return c.merge.matcher.global; }, "global");
  expectEveryNameRoundTrips<RefinementMethod>(
      [](PipelineConfig & c) -> auto& { return c.merge.matcher.refinement; }, "refinement");
  expectEveryNameRoundTrips<MatchScoreKind>(
      [](PipelineConfig & c) -> auto& { return c.merge.matcher.score.kind; }, "kind");
  expectEveryNameRoundTrips<MatchChannels>(
      [](PipelineConfig & c) -> auto& { return c.merge.matcher.score.channels; }, "channels");
  expectEveryNameRoundTrips<CorrelationStatistic>(
      [](PipelineConfig & c) -> auto& { return c.merge.geometry_matcher.search.statistic; },
      "statistic");
  expectEveryNameRoundTrips<RobustLoss>(
      [](PipelineConfig & c) -> auto& { return c.merge.graph.inter_session_loss; },
      "inter_session_loss");
  expectEveryNameRoundTrips<PairMatching>(
      [](PipelineConfig & c) -> auto& { return c.merge.pair_matching; }, "pair_matching");
}

TEST(ConfigIo, TheShippedConfigIsTheDefaults) {
  const PipelineConfig shipped =
      loadPipelineConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "mm4mm.yaml");
  EXPECT_EQ(pipelineConfigYaml(shipped), pipelineConfigYaml(PipelineConfig{}));
}

TEST(ConfigIo, AFileOnlyOverridesTheKeysItNames) {
  const PipelineConfig c = parseChecked(
      "merge:\n  matcher:\n    min_z: 7.5\n    score:\n      statistic: concordance\n"
      "  pair_matching: growing\noutputs:\n  octomap:\n    resolution_m: 0.25\n");
  EXPECT_EQ(c.merge.matcher.min_z, 7.5);
  EXPECT_EQ(c.merge.matcher.score.statistic, CorrelationStatistic::kConcordance);
  EXPECT_EQ(c.merge.pair_matching, PairMatching::kGrowingMap);
  EXPECT_EQ(c.outputs.octomap.resolution_m, 0.25);
  PipelineConfig expected;
  expected.merge.matcher.min_z = 7.5;
  expected.merge.matcher.score.statistic = CorrelationStatistic::kConcordance;
  expected.merge.pair_matching = PairMatching::kGrowingMap;
  expected.outputs.octomap.resolution_m = 0.25;
  EXPECT_EQ(pipelineConfigYaml(c), pipelineConfigYaml(expected));
  // The defaults written inside MergeConfig's own initialisers stay what they were.
  EXPECT_EQ(c.merge.point_map.voxel_size_m, 0.25);
  EXPECT_EQ(c.merge.geometry_matcher.max_second_ratio, 0.5);
  EXPECT_EQ(c.merge.edges.icp.voxel_sizes_m, (std::vector<double>{0.5, 0.25}));
  EXPECT_EQ(c.merge.matcher.pso.particles, 24);
  EXPECT_EQ(c.merge.matcher.paper_pso.particles, 200);
}

TEST(ConfigIo, AnUnknownNestedKeyIsNamedByItsPathAndLine) {
  const std::string e = errorOf("merge:\n  matcher:\n    single_track:\n      min_zz: 3\n");
  EXPECT_NE(e.find("test.yaml:4: unknown key 'merge.matcher.single_track.min_zz'"),
            std::string::npos)
      << e;
  EXPECT_NE(errorOf("outputs:\n  cloud: {}\n  octomapp: {}\n").find("test.yaml:3:"),
            std::string::npos);
  EXPECT_NE(errorOf("mergee: {}\n").find("unknown key 'mergee'"), std::string::npos);
}

TEST(ConfigIo, AMatcherFileOfTheOldFormatIsSaidToBeOne) {
  const std::string e = errorOf("calibration:\n  enabled: true\nglobal:\n  yaw_step_deg: 2\n");
  EXPECT_NE(e.find("test.yaml:1: unknown key 'calibration': a matcher file of the old format"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("merge.matcher"), std::string::npos) << e;
}

TEST(ConfigIo, AWrongTypeIsNamedByItsPath) {
  EXPECT_NE(errorOf("merge:\n  graph:\n    max_iterations: 2.5\n")
                .find("test.yaml:3: 'merge.graph.max_iterations' has the wrong type"),
            std::string::npos);
  EXPECT_NE(errorOf("merge:\n  pair_icp:\n    voxel_sizes_m: 0.5\n")
                .find("'merge.pair_icp.voxel_sizes_m' has the wrong type"),
            std::string::npos);
  EXPECT_NE(errorOf("merge:\n  joint:\n    enabled: maybe\n")
                .find("'merge.joint.enabled' has the wrong type"),
            std::string::npos);
  EXPECT_NE(errorOf("merge:\n  matcher: 3\n").find("test.yaml:2: 'merge.matcher' must be a map"),
            std::string::npos);
}

TEST(ConfigIo, AnUnknownEnumNameListsTheNamesAllowed) {
  const std::string e = errorOf("merge:\n  matcher:\n    refinement: newton\n");
  EXPECT_NE(e.find("test.yaml:3: 'merge.matcher.refinement' must be one of pso, local_grid, none, "
                   "got 'newton'"),
            std::string::npos)
      << e;
}

TEST(ConfigIo, AnInvalidValueIsNamedByItsKeyAndLine) {
  std::string e = errorOf("merge:\n  matcher:\n    pso:\n      particles: 1\n");
  EXPECT_NE(e.find("test.yaml:4: merge.matcher.pso.particles must be >= 2"), std::string::npos)
      << e;
  e = errorOf(
      "outputs:\n  magnetic:\n    map:\n      gaussian_process:\n"
      "        max_std_ratio: 1.5\n");
  EXPECT_NE(e.find("test.yaml:5: outputs.magnetic.map.gaussian_process.max_std_ratio"),
            std::string::npos)
      << e;
  e = errorOf("merge:\n  edges:\n    icp:\n      voxel_sizes_m: [0.25, 0.5]\n");
  EXPECT_NE(e.find("test.yaml:4: merge.edges.icp.voxel_sizes_m must be strictly decreasing"),
            std::string::npos)
      << e;
  // A rule between two keys names the first; the line is the deepest of its parents given.
  e = errorOf("merge:\n  structure_map:\n    cell_size_m: 0.3\n");
  EXPECT_NE(e.find("test.yaml:1: merge.geometry_matcher.map.cell_size_m must equal "
                   "structure_map.cell_size_m"),
            std::string::npos)
      << e;
  // The same settings without the check are read as written.
  EXPECT_EQ(parse("merge:\n  matcher:\n    pso:\n      particles: 1\n").merge.matcher.pso.particles,
            1);
}

TEST(ConfigIo, AFileIsReadFromDiskWithItsNameInErrors) {
  const fs::path dir =
      fs::temp_directory_path() / ("mm4mm_config_io_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "c.yaml") << "merge:\n  graph:\n    threads: 0\n";
  try {
    loadPipelineConfig(dir / "c.yaml");
    FAIL() << "threads 0 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("c.yaml:3: merge.graph.threads must be >= 1"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(loadPipelineConfig(dir / "missing.yaml"), InputError);
  std::ofstream(dir / "empty.yaml") << "";
  EXPECT_EQ(pipelineConfigYaml(loadPipelineConfig(dir / "empty.yaml")),
            pipelineConfigYaml(PipelineConfig{}));
  fs::remove_all(dir);
}

}  // namespace
