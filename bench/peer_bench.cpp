// mm4mm against the registration pipelines users would use instead, on the same simulated
// sessions in one run (issue 5; the paper's Table I). Every method sees the same inputs: each
// session's point map (0.25 m voxels, its own frame; the identity is the initial guess where a
// method takes one) and, for mm4mm, the sessions themselves.
//
// Comparisons (the paper's Table I): sessions 1+2, 3+4, (1+2)+(3+4) and all at once; the corridor
// has three sessions (1+2, 2+3, all); "disjoint" puts a session that overlaps nothing beside
// session 1. A comparison succeeds when every session pair it evaluates that truly overlaps is
// aligned (docs/design.md metric 1: median overlap error below 0.5 m and 2°); a disjoint comparison
// succeeds when the method refuses to place the disjoint session. A comparison none of whose
// judged pairs truly overlaps (random starts) is left out. Time: every registration or merge a
// comparison needs, also when a smaller comparison computed it first; peak RSS: this process's
// high-water mark during the comparison (or the Open3D child's, when larger).
//
// Pairwise methods build the larger comparisons the way a user would: (1+2)+(3+4) registers the
// cloud of 3+4 (placed by the method's own 3+4 answer) onto the cloud of 1+2; "all" chains
// consecutive pairs. mm4mm merges the sessions of a comparison in one graph; its (1+2)+(3+4) is
// the four-session merge, evaluated on the pairs across the two halves.
//
// The sessions' magnetometers are calibrated once per scenario, as `mm4mm merge` does before it
// merges (runs before 2026-12-03 merged them uncalibrated); a merge's time includes it.
//
// Every method may refuse. mm4mm refuses by its own rules; the paper's baseline (mm4mm-paper) by
// the default's confidence rule (MagneticMatcherConfig::paper_confidence_rule). A cloud method
// (PCL's, Open3D's, ICP-EM from identity) claims an overlap only when it converged and its fit
// (Open3D's fitness and inlier RMSE within 0.5 m, measured alike for all by PCL's correspondence
// estimation) passes the method's claim rule, read with --claim-rules from the file
// scripts/choose_peer_rules.py chose on tuning seeds from the rows --pairs-csv writes.
//
// Usage: peer_bench [--seeds N] [--first-seed S] [--presets a,b] [--methods a,b] [--csv FILE]
//                   [--claim-rules FILE] [--pairs-csv FILE]
// Presets: warehouse, corridor, random, disjoint. Methods: mm4mm, mm4mm-magnetic-only,
// mm4mm-icp-identity, mm4mm-paper, mm4mm-no-magnetic-residuals, pcl-gicp, pcl-ndt,
// pcl-fpfh-sacia-gicp, open3d-fpfh-ransac-icp. Prints a markdown table; writes one CSV row per
// method, comparison and seed.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "bench_util.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/geometry/icp_em.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "peer_registration.hpp"
#include "peer_scenarios.hpp"

namespace {

using namespace mm4mm;
using bench::median;
using bench::parseFlags;
using bench::splitList;
using peers::Comparison;
using peers::comparisonsFor;
using peers::Scenario;
using peers::simulateScenario;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

// Where a method put the sessions of a comparison: keyframe poses in the first session's frame
// (empty: not placed), and the rigid session frame the paper's e_t / e_r judge.
struct Placement {
  std::map<int, std::vector<Eigen::Isometry3d>> keyframes;
  std::map<int, Eigen::Isometry3d> frames;
  double seconds = 0.0;  // every registration or merge the placement needed, reused ones too
  double peak_mb = 0.0;  // the high-water mark while a remembered merge ran (0: measured now)
};

void placeRigidly(const Session& session, int id, const Eigen::Isometry3d& T, Placement* out) {
  out->frames[id] = T;
  out->keyframes[id] = placeOdometry({&session}, {T}).front();
}

// Pairwise methods: T_a_b from the point maps (or sessions), or nothing when the method refuses.
using PairRegistration =
    std::function<std::optional<Eigen::Isometry3d>(const Scenario&, int a, int b)>;
// The same with the seconds the registration took (a remembered answer keeps its first cost).
using TimedPairRegistration = std::function<std::pair<std::optional<Eigen::Isometry3d>, double>(
    const Scenario&, int a, int b)>;
// Registration of two arbitrary clouds (for (1+2)+(3+4)); null where the method cannot, and
// the two halves are then joined through the pair of sessions 2 and 3.
using CloudRegistration =
    std::function<std::optional<Eigen::Isometry3d>(const PointCloud&, const PointCloud&)>;
// A cloud method's raw answer, before its claim rule decides whether it claims an overlap.
using PeerRegistration =
    std::function<peers::PeerResult(const PointCloud& target, const PointCloud& source)>;

// Every pair registration of a cloud method, with its fit and the truth, for
// scripts/choose_peer_rules.py (--pairs-csv): the rows a claim rule is chosen on.
std::ofstream* pair_log = nullptr;

PointCloud unionCloud(const PointCloud& a, const PointCloud& b, const Eigen::Isometry3d& T_a_b) {
  PointCloud out = a;
  const Eigen::Isometry3f T = T_a_b.cast<float>();
  for (const Eigen::Vector3f& p : b) out.push_back(T * p);
  return out;
}

Placement placeByPairs(const Scenario& s, const Comparison& c, const TimedPairRegistration& timed,
                       const CloudRegistration& clouds) {
  Placement out;
  const auto pair = [&](int a, int b) {
    const auto [T, seconds] = timed(s, a, b);
    out.seconds += seconds;
    return T;
  };
  const int first = c.sessions.front();
  placeRigidly(s.sessions[first], first, Eigen::Isometry3d::Identity(), &out);
  if (c.name == "(1+2)+(3+4)") {
    const auto T01 = pair(0, 1), T23 = pair(2, 3);
    if (T01) placeRigidly(s.sessions[1], 1, *T01, &out);
    if (!T01 || !T23) return out;
    std::optional<Eigen::Isometry3d> T02;
    if (clouds) {
      const auto start = Clock::now();
      T02 = clouds(unionCloud(s.maps[0], s.maps[1], *T01), unionCloud(s.maps[2], s.maps[3], *T23));
      out.seconds += std::chrono::duration<double>(Clock::now() - start).count();
    } else if (const auto T12 = pair(1, 2)) {
      T02 = *T01 * *T12;  // no cloud registration: the halves meet where sessions 2 and 3 do
    }
    if (!T02) return out;
    placeRigidly(s.sessions[2], 2, *T02, &out);
    placeRigidly(s.sessions[3], 3, *T02 * *T23, &out);
    return out;
  }
  // Pairs and "all": a chain of consecutive sessions, stopping at the first refusal.
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (std::size_t k = 1; k < c.sessions.size(); ++k) {
    const auto step = pair(c.sessions[k - 1], c.sessions[k]);
    if (!step) break;
    T = T * *step;
    placeRigidly(s.sessions[c.sessions[k]], c.sessions[k], T, &out);
  }
  return out;
}

Placement placeByMerge(const Scenario& s, const Comparison& c, const MergeConfig& config) {
  std::vector<Session> subset;
  for (int id : c.sessions) subset.push_back(s.sessions[id]);
  const auto start = Clock::now();
  const MergeResult result = mergeSessions(subset, config);
  Placement out;
  // The calibration ran once for the scenario (simulateScenario), as `mm4mm merge` runs it first.
  out.seconds = s.calibration_s + std::chrono::duration<double>(Clock::now() - start).count();
  for (std::size_t k = 0; k < c.sessions.size(); ++k)
    if (result.solution.connected[k]) {
      out.keyframes[c.sessions[k]] = result.solution.T_atlas_keyframe[k];
      out.frames[c.sessions[k]] = result.solution.T_atlas_session[k];
    }
  return out;
}

struct Outcome {
  bool applicable = true;  // false: no judged pair truly overlaps (random starts), not counted
  bool success = false;
  double overlap_t = 0, overlap_r = 0;  // median over the judged pairs
  std::vector<double> frame_t, frame_r;
  double seconds = 0, peak_mb = 0;
};

Outcome judge(const Scenario& s, const Comparison& c, const Placement& p) {
  Outcome o;
  const int first = c.sessions.front();
  if (c.disjoint) {
    o.success = !p.keyframes.count(c.sessions[1]);
    o.overlap_t = o.overlap_r = -1.0;  // nothing to align
    return o;
  }
  std::vector<double> t, r;
  bool all_aligned = true;
  int judged = 0;
  for (const auto& [a, b] : c.judged) {
    const Session& A = s.sessions[a];
    const Session& B = s.sessions[b];
    if (overlapError(A, B, trueRelativeTransform(A, B)).pairs < 10) continue;  // no true overlap
    ++judged;
    if (!p.keyframes.count(a) || !p.keyframes.count(b)) {
      all_aligned = false;
      continue;
    }
    const OverlapError e = overlapError(A, B, p.keyframes.at(a), p.keyframes.at(b));
    t.push_back(e.median_translation_m), r.push_back(e.median_rotation_deg);
    all_aligned = all_aligned && e.aligned();
  }
  o.applicable = judged > 0;
  o.success = o.applicable && all_aligned;
  o.overlap_t = t.empty() ? -1.0 : median(t);
  o.overlap_r = r.empty() ? -1.0 : median(r);
  // The paper's Table I judges (1+2)+(3+4) by where the second half lands: session 3's frame.
  for (int id : c.sessions)
    if (id != first && p.frames.count(id) && (c.name != "(1+2)+(3+4)" || id == 2)) {
      const FrameError f = frameError(s.sessions[first], s.sessions[id], p.frames.at(id));
      o.frame_t.push_back(f.translation_m), o.frame_r.push_back(f.rotation_deg);
    }
  return o;
}

// One method, ready to place the sessions of any comparison of a scenario. Pairwise methods
// remember their pair answers within a scenario: "all" reuses the pairs' registrations.
class Method {
 public:
  virtual ~Method() = default;
  virtual Placement place(const Scenario& s, const Comparison& c) = 0;
  virtual double childPeakMb() const { return 0.0; }
};

class MergeMethod : public Method {
 public:
  explicit MergeMethod(MergeConfig config) : config_(std::move(config)) {}
  Placement place(const Scenario& s, const Comparison& c) override {
    // (1+2)+(3+4) and all are the same four-session merge: solve it once.
    std::string key = s.preset + std::to_string(s.seed);
    for (int id : c.sessions) key += "," + std::to_string(id);
    if (cache_key_ != key) {
      cached_ = placeByMerge(s, c, config_);
      cached_.peak_mb = bench::residentMb("VmHWM:");
      cache_key_ = key;
    }
    return cached_;
  }

 private:
  MergeConfig config_;
  std::string cache_key_;
  Placement cached_;
};

class PairwiseMethod : public Method {
 public:
  PairwiseMethod(PairRegistration pair, CloudRegistration clouds)
      : pair_(std::move(pair)), clouds_(std::move(clouds)) {}
  Placement place(const Scenario& s, const Comparison& c) override {
    if (scenario_ != &s) memo_.clear(), scenario_ = &s;
    const TimedPairRegistration memoised = [this](const Scenario& sc, int a, int b) {
      const auto key = std::make_pair(a, b);
      if (!memo_.count(key)) {
        const auto start = Clock::now();
        const auto T = pair_(sc, a, b);
        memo_[key] = {T, std::chrono::duration<double>(Clock::now() - start).count()};
      }
      return memo_[key];
    };
    return placeByPairs(s, c, memoised, clouds_);
  }

 private:
  PairRegistration pair_;
  CloudRegistration clouds_;
  const Scenario* scenario_ = nullptr;
  std::map<std::pair<int, int>, std::pair<std::optional<Eigen::Isometry3d>, double>> memo_;
};

// Cloud-to-cloud methods used for pairs and for (1+2)+(3+4) alike. A method claims an overlap
// only where its claim rule accepts its answer (converged, fit good enough); otherwise it
// refuses, as mm4mm does when unsure.
class CloudMethod : public PairwiseMethod {
 public:
  CloudMethod(const std::string& name, const PeerRegistration& registration,
              const peers::ClaimRule& rule)
      : PairwiseMethod(
            [name, registration, rule](const Scenario& s, int a,
                                       int b) -> std::optional<Eigen::Isometry3d> {
              const peers::PeerResult r = judged(registration, s.maps[a], s.maps[b]);
              if (pair_log) logPair(name, s, a, b, r, rule.claims(r));
              if (!rule.claims(r)) return std::nullopt;
              return r.T_target_source;
            },
            [registration, rule](const PointCloud& t,
                                 const PointCloud& src) -> std::optional<Eigen::Isometry3d> {
              const peers::PeerResult r = judged(registration, t, src);
              if (!rule.claims(r)) return std::nullopt;
              return r.T_target_source;
            }) {}

 private:
  static peers::PeerResult judged(const PeerRegistration& registration, const PointCloud& target,
                                  const PointCloud& source) {
    peers::PeerResult r = registration(target, source);
    peers::measureFit(target, source, &r);
    return r;
  }
  static void logPair(const std::string& name, const Scenario& s, int a, int b,
                      const peers::PeerResult& r, bool claimed) {
    const Session& A = s.sessions[a];
    const Session& B = s.sessions[b];
    const bool overlaps = overlapError(A, B, trueRelativeTransform(A, B)).pairs >= 10;
    const OverlapError e = overlapError(A, B, r.T_target_source);
    char line[256];
    std::snprintf(line, sizeof(line), "%s,%d,%d,%d,%s,%d,%.4f,%.4f,%d,%d,%d\n", s.preset.c_str(),
                  s.seed, a, b, name.c_str(), r.converged, r.fitness, r.inlier_rmse_m, overlaps,
                  overlaps && e.aligned(), claimed);
    *pair_log << line << std::flush;
  }
};

std::unique_ptr<Method> makeMethod(const std::string& name, double* open3d_peak_mb,
                                   const std::map<std::string, peers::ClaimRule>& rules) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  const peers::ClaimRule rule = rules.count(name) ? rules.at(name) : peers::ClaimRule{};
  const auto cloud_method = [&](const PeerRegistration& registration) {
    return std::make_unique<CloudMethod>(name, registration, rule);
  };
  if (name == "mm4mm") return std::make_unique<MergeMethod>(MergeConfig{});
  if (name == "mm4mm-paper") {
    MergeConfig config;
    config.matcher.global = GlobalSearchMethod::kPaperPso;
    config.matcher.score.kind = MatchScoreKind::kPaperFitness;
    config.matcher.score.stride = 6;
    config.matcher.paper_pso.particles = 100;
    config.matcher.paper_pso.iterations = 60;
    config.matcher.paper_confidence_rule = true;  // refuses as the default does
    return std::make_unique<MergeMethod>(config);
  }
  if (name == "mm4mm-no-magnetic-residuals") {
    MergeConfig config;
    config.graph.use_magnetic_residuals = false;
    return std::make_unique<MergeMethod>(config);
  }
  if (name == "mm4mm-magnetic-only")
    return std::make_unique<PairwiseMethod>(
        [](const Scenario& s, int a, int b) -> std::optional<Eigen::Isometry3d> {
          const MagneticMatchResult r =
              matchSessions(s.sessions[a], s.sessions[b], MagneticMatcherConfig{});
          if (!r.overlap()) return std::nullopt;
          return r.T_a_b.toIsometry();
        },
        nullptr);
  if (name == "mm4mm-icp-identity")
    return cloud_method([identity](const PointCloud& t, const PointCloud& s) {
      const IcpEmResult r = refineIcpEm(t, s, identity, IcpEmConfig{});
      return peers::PeerResult{r.T_a_b, r.converged};
    });
  if (name == "pcl-gicp")
    return cloud_method([identity](const PointCloud& t, const PointCloud& s) {
      return peers::registerGicp(t, s, identity);
    });
  if (name == "pcl-ndt")
    return cloud_method([identity](const PointCloud& t, const PointCloud& s) {
      return peers::registerNdt(t, s, identity);
    });
  if (name == "pcl-fpfh-sacia-gicp")
    return cloud_method([](const PointCloud& t, const PointCloud& s) {
      return peers::registerFpfhSacIaGicp(t, s, 1);
    });
  if (name == "open3d-fpfh-ransac-icp")
    // Open3D reports no convergence flag: its answer counts as converged, the fit decides.
    return cloud_method([open3d_peak_mb](const PointCloud& t, const PointCloud& s) {
      return peers::PeerResult{peers::registerOpen3d(t, s, 1, open3d_peak_mb), true};
    });
  throw std::invalid_argument("unknown method " + name);
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 10, first_seed = 1;
  std::vector<std::string> presets{"warehouse", "corridor", "random", "disjoint"};
  std::vector<std::string> methods{
      "mm4mm",       "mm4mm-magnetic-only",         "mm4mm-icp-identity",
      "mm4mm-paper", "mm4mm-no-magnetic-residuals", "pcl-gicp",
      "pcl-ndt",     "pcl-fpfh-sacia-gicp",         "open3d-fpfh-ransac-icp"};
  std::string csv_path = "peer_bench.csv", rules_path, pairs_path;
  for (const auto& [flag, value] :
       parseFlags(argc, argv,
                  {"--seeds", "--first-seed", "--presets", "--methods", "--csv", "--claim-rules",
                   "--pairs-csv"},
                  "peer_bench [--seeds N] [--first-seed S] [--presets a,b] [--methods a,b] "
                  "[--csv FILE] [--claim-rules FILE] [--pairs-csv FILE]")) {
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--presets") presets = splitList(value);
    if (flag == "--methods") methods = splitList(value);
    if (flag == "--csv") csv_path = value;
    if (flag == "--claim-rules") rules_path = value;
    if (flag == "--pairs-csv") pairs_path = value;
  }
  const std::map<std::string, peers::ClaimRule> rules = peers::readClaimRules(rules_path);
  std::ofstream pairs_csv;
  if (!pairs_path.empty()) {
    pairs_csv.open(pairs_path);
    pairs_csv << "preset,seed,a,b,method,converged,fitness,inlier_rmse_m,overlaps,aligned,"
                 "claimed\n";
    pair_log = &pairs_csv;
  }
  std::ofstream csv(csv_path);
  csv << "preset,seed,comparison,method,success,overlap_error_m,overlap_error_deg,e_t_m,e_r_deg,"
         "seconds,peak_rss_mb\n";
  // (preset, comparison, method) -> outcomes over seeds
  std::map<std::tuple<std::string, std::string, std::string>, std::vector<Outcome>> results;
  // Issue 5's speed target: a 4-session warehouse merge against PCL's GICP on the two largest
  // session clouds of the same seed (identity guess), both timed here.
  std::vector<double> merge_seconds, gicp_seconds;
  for (const std::string& preset : presets)
    for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
      const Scenario scenario = simulateScenario(preset, seed);
      for (const std::string& name : methods) {
        double open3d_peak_mb = 0.0;
        const std::unique_ptr<Method> method = makeMethod(name, &open3d_peak_mb, rules);
        for (const Comparison& c : comparisonsFor(scenario)) {
          bench::resetPeakRss();
          open3d_peak_mb = 0.0;
          const Placement placement = method->place(scenario, c);
          Outcome o = judge(scenario, c, placement);
          if (!o.applicable) continue;
          o.seconds = placement.seconds;
          o.peak_mb = std::max({bench::residentMb("VmHWM:"), open3d_peak_mb, placement.peak_mb});
          results[{preset, c.name, name}].push_back(o);
          if (preset == "warehouse" && name == "mm4mm" && c.name == "all")
            merge_seconds.push_back(o.seconds);
          char line[512];
          std::snprintf(line, sizeof(line), "%s,%d,%s,%s,%d,%.4f,%.4f,%.4f,%.4f,%.2f,%.0f\n",
                        preset.c_str(), seed, c.name.c_str(), name.c_str(), o.success, o.overlap_t,
                        o.overlap_r, o.frame_t.empty() ? -1.0 : mean(o.frame_t),
                        o.frame_r.empty() ? -1.0 : mean(o.frame_r), o.seconds, o.peak_mb);
          csv << line << std::flush;
          std::fprintf(stderr, "%s", line);
        }
      }
      if (preset == "warehouse") {
        std::vector<std::size_t> order(scenario.maps.size());
        std::iota(order.begin(), order.end(), 0);
        std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
          return scenario.maps[x].size() > scenario.maps[y].size();
        });
        const auto start = Clock::now();
        peers::registerGicp(scenario.maps[order[0]], scenario.maps[order[1]],
                            Eigen::Isometry3d::Identity());
        gicp_seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
      }
    }

  std::printf(
      "| preset | comparison | method | success | median overlap error (m / °) | mean e_t (m) / "
      "e_r (°) | median s | peak RSS (MB) |\n|---|---|---|---|---|---|---|---|\n");
  for (const auto& [key, outcomes] : results) {
    const auto& [preset, comparison, method] = key;
    int success = 0;
    std::vector<double> t, r, ft, fr, seconds, peak;
    for (const Outcome& o : outcomes) {
      success += o.success;
      if (o.overlap_t >= 0) t.push_back(o.overlap_t), r.push_back(o.overlap_r);
      ft.insert(ft.end(), o.frame_t.begin(), o.frame_t.end());
      fr.insert(fr.end(), o.frame_r.begin(), o.frame_r.end());
      seconds.push_back(o.seconds), peak.push_back(o.peak_mb);
    }
    const auto figure = [](const std::vector<double>& v, const char* format,
                           bool use_mean = false) {
      char text[32];
      if (v.empty()) return std::string("–");
      const double value = use_mean ? mean(v) : median(v);
      std::snprintf(text, sizeof(text), format, value);
      return std::string(text);
    };
    std::printf("| %s | %s | %s | %d/%zu (%.0f %%) | %s / %s | %s / %s | %.1f | %.0f |\n",
                preset.c_str(), comparison.c_str(), method.c_str(), success, outcomes.size(),
                100.0 * success / outcomes.size(), figure(t, "%.3f").c_str(),
                figure(r, "%.2f").c_str(), figure(ft, "%.3f", true).c_str(),
                figure(fr, "%.2f", true).c_str(), median(seconds),
                *std::max_element(peak.begin(), peak.end()));
  }
  // Per seed, then the mean ratio: with few seeds a median would be one of them.
  if (!merge_seconds.empty() && merge_seconds.size() == gicp_seconds.size()) {
    std::printf(
        "\n4-session warehouse merge (matching, ICP-EM, graph; no atlas files) against PCL GICP on "
        "the two largest session clouds of the same seed (target: ratio <= 3):\n");
    std::vector<double> ratios;
    for (std::size_t k = 0; k < merge_seconds.size(); ++k) {
      ratios.push_back(merge_seconds[k] / gicp_seconds[k]);
      std::printf("- seed %d: merge %.1f s, GICP %.1f s, ratio %.1f\n",
                  first_seed + static_cast<int>(k), merge_seconds[k], gicp_seconds[k],
                  ratios.back());
    }
    std::printf("- mean ratio %.1f\n", mean(ratios));
  }
  return 0;
}
