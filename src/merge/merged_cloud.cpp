#include "mm4mm/merge/merged_cloud.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <tuple>

namespace mm4mm {
namespace {

// Voxel indices are packed into one sortable key, 21 bits per axis with a bias: points farther
// than 2^20 voxels from the atlas origin along an axis (100 km at 0.1 m) are dropped.
constexpr std::int64_t kBias = std::int64_t{1} << 20;
constexpr std::int64_t kMask = (std::int64_t{1} << 21) - 1;

using Voxel = std::array<std::int64_t, 3>;

std::uint64_t packVoxel(const Voxel& v) {
  return (static_cast<std::uint64_t>(v[0] + kBias) << 42) |
         (static_cast<std::uint64_t>(v[1] + kBias) << 21) |
         static_cast<std::uint64_t>(v[2] + kBias);
}

Voxel unpackVoxel(std::uint64_t key) {
  return {static_cast<std::int64_t>((key >> 42) & kMask) - kBias,
          static_cast<std::int64_t>((key >> 21) & kMask) - kBias,
          static_cast<std::int64_t>(key & kMask) - kBias};
}

bool inKeyRange(const Voxel& v) {
  return std::all_of(v.begin(), v.end(), [](std::int64_t i) { return i >= -kBias && i < kBias; });
}

// One scan return in the atlas frame: its voxel and its position relative to the voxel's
// corner (small numbers, so float keeps sub-micrometre precision anywhere in the atlas).
struct Return {
  std::uint64_t key;
  Eigen::Vector3f local;
};

// One session's Gaussian for one voxel (Eq. 13's per-map point): n returns with mean `mean`
// (relative to the voxel's corner) and position covariance `covariance` = (S + sigma^2 I) / n.
struct SessionVoxel {
  std::uint64_t key;
  std::uint32_t session;
  std::uint32_t returns;
  Eigen::Vector3f mean;
  Eigen::Matrix3f covariance;
};

constexpr std::uint64_t kOutOfRange = std::numeric_limits<std::uint64_t>::max();

// Every return of one session within the range band, moved into the atlas frame, into
// `returns` (a buffer reused across sessions: fresh memory costs page faults, which are slow in
// virtual machines). Returns beyond the key range get the key kOutOfRange.
void sessionReturns(const Session& session, const std::vector<Eigen::Isometry3d>& T_atlas_keyframe,
                    const MergedCloudConfig& config, std::vector<Return>* returns) {
  const Eigen::Vector3f lidar_body = session.rig.T_body_lidar.translation().cast<float>();
  const float min_range2 = static_cast<float>(config.min_range_m * config.min_range_m);
  const float max_range2 = static_cast<float>(config.max_range_m * config.max_range_m);
  const auto keep = [&](const Eigen::Vector3f& p_body) {
    if (!p_body.allFinite()) return false;
    const float range2 = (p_body - lidar_body).squaredNorm();
    return range2 >= min_range2 && range2 <= max_range2;
  };
  // Two passes over the scans: count, then fill each scan's slice of one buffer.
  std::vector<std::size_t> offset(session.scans.size() + 1, 0);
  tbb::parallel_for(std::size_t{0}, session.scans.size(), [&](std::size_t k) {
    offset[k + 1] = static_cast<std::size_t>(
        std::count_if(session.scans[k].begin(), session.scans[k].end(), keep));
  });
  for (std::size_t k = 0; k < session.scans.size(); ++k) offset[k + 1] += offset[k];
  returns->resize(offset.back());
  const double inverse_voxel = 1.0 / config.voxel_size_m;
  tbb::parallel_for(std::size_t{0}, session.scans.size(), [&](std::size_t k) {
    const Eigen::Isometry3d& T_atlas_body = T_atlas_keyframe[k];
    Return* out = returns->data() + offset[k];
    for (const Eigen::Vector3f& p_body : session.scans[k]) {
      if (!keep(p_body)) continue;
      const Eigen::Vector3d p = T_atlas_body * p_body.cast<double>();
      const Eigen::Vector3d cell = (p * inverse_voxel).array().floor();
      const Voxel v{static_cast<std::int64_t>(cell.x()), static_cast<std::int64_t>(cell.y()),
                    static_cast<std::int64_t>(cell.z())};
      *out++ = inKeyRange(v) ? Return{packVoxel(v), (p - cell * config.voxel_size_m).cast<float>()}
                             : Return{kOutOfRange, Eigen::Vector3f::Zero()};
    }
  });
}

// Voxelises one session's returns (sorted here, in place) into one Gaussian per voxel, in key
// order (see MergedCloud::covariances).
std::vector<SessionVoxel> sessionVoxels(std::vector<Return>* returns, std::uint32_t session,
                                        double sigma_m) {
  // parallel_sort is not stable and splits by thread count, and the sums below depend on the
  // order of a voxel's returns, so each voxel's returns are then ordered by position: one total
  // order, whatever the threads. Sorting by key alone first and each voxel's few returns after
  // costs less than comparing positions across millions of returns.
  tbb::parallel_sort(returns->begin(), returns->end(),
                     [](const Return& a, const Return& b) { return a.key < b.key; });
  std::vector<Return>& r = *returns;
  std::vector<std::size_t> starts;
  for (std::size_t i = 0; i < r.size() && r[i].key != kOutOfRange; ++i)
    if (i == 0 || r[i].key != r[i - 1].key) starts.push_back(i);
  starts.push_back(starts.empty() ? 0
                                  : static_cast<std::size_t>(
                                        std::lower_bound(r.begin(), r.end(), kOutOfRange,
                                                         [](const Return& a, std::uint64_t key) {
                                                           return a.key < key;
                                                         }) -
                                        r.begin()));
  std::vector<SessionVoxel> voxels(starts.size() - 1);
  const Eigen::Matrix3d noise = sigma_m * sigma_m * Eigen::Matrix3d::Identity();
  tbb::parallel_for(std::size_t{0}, voxels.size(), [&](std::size_t v) {
    const std::size_t begin = starts[v], end = starts[v + 1];
    std::sort(r.begin() + begin, r.begin() + end, [](const Return& a, const Return& b) {
      return std::tie(a.local.x(), a.local.y(), a.local.z()) <
             std::tie(b.local.x(), b.local.y(), b.local.z());
    });
    const double n = static_cast<double>(end - begin);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t i = begin; i < end; ++i) mean += r[i].local.cast<double>();
    mean /= n;
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (std::size_t i = begin; i < end; ++i) {
      const Eigen::Vector3d d = r[i].local.cast<double>() - mean;
      scatter.noalias() += d * d.transpose();
    }
    voxels[v] = {r[begin].key, session, static_cast<std::uint32_t>(end - begin), mean.cast<float>(),
                 ((scatter / n + noise) / n).cast<float>()};
  });
  return voxels;
}

// Information-form accumulator of a product of Gaussians (Eq. 13's fusion of matched points):
// Lambda = sum Sigma_s^-1, eta = sum Sigma_s^-1 mu_s; the product has covariance Lambda^-1 and
// mean Lambda^-1 eta. Means are relative to one voxel's corner.
struct Fusion {
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  Eigen::Vector3d information_mean = Eigen::Vector3d::Zero();
  std::uint32_t returns = 0;
  std::uint32_t best_returns = 0;
  std::uint32_t best_session = 0;
  std::uint16_t sessions = 0;

  // Adds `v`, whose voxel's corner lies `offset_m` from this one's.
  void add(const SessionVoxel& v, const Eigen::Vector3d& offset_m) {
    const Eigen::Matrix3d info = v.covariance.cast<double>().inverse();
    information += info;
    information_mean += info * (v.mean.cast<double>() + offset_m);
    returns += v.returns;
    ++sessions;
    if (v.returns > best_returns || (v.returns == best_returns && v.session < best_session)) {
      best_returns = v.returns;
      best_session = v.session;
    }
  }
};

// Open-addressing hash map from voxel key to group index: neighbour look-ups are random
// accesses, one cache miss each here against about twenty for a binary search.
class KeyIndex {
 public:
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

  explicit KeyIndex(const std::vector<std::uint64_t>& keys) {
    int bits = 4;
    while ((std::size_t{1} << bits) < 2 * keys.size()) ++bits;
    shift_ = 64 - bits;
    mask_ = (std::size_t{1} << bits) - 1;
    keys_.assign(mask_ + 1, 0);
    values_.assign(mask_ + 1, kNone);
    for (std::size_t g = 0; g < keys.size(); ++g) {
      std::size_t i = slot(keys[g]);
      while (values_[i] != kNone) i = (i + 1) & mask_;
      keys_[i] = keys[g];
      values_[i] = static_cast<std::uint32_t>(g);
    }
  }

  std::uint32_t find(std::uint64_t key) const {
    for (std::size_t i = slot(key);; i = (i + 1) & mask_) {
      if (values_[i] == kNone) return kNone;
      if (keys_[i] == key) return values_[i];
    }
  }

 private:
  std::size_t slot(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
  }

  int shift_ = 60;
  std::size_t mask_ = 15;
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> values_;
};

// Fuses session voxels: first all sessions' Gaussians in one voxel, then each lone one (a voxel
// only one session hit) with the nearest point of other sessions next door. Works on groups,
// one per occupied voxel, in key order; a joined lone group is dropped from the output.
class Fuser {
 public:
  // `per_session` holds each session's voxels in key order.
  Fuser(std::vector<std::vector<SessionVoxel>> per_session, const MergedCloudConfig& config)
      : per_session_(std::move(per_session)), voxel_m_(config.voxel_size_m) {
    groupByVoxel();
    const std::size_t groups = keys_.size();
    target_.assign(groups, kNone);
    absorbed_head_.assign(groups, kNone);
    next_absorbed_.assign(groups, kNone);
    cloud_.points.resize(groups);
    cloud_.covariances.resize(groups);
    cloud_.session.resize(groups);
    cloud_.session_count.resize(groups);
    cloud_.return_count.resize(groups);
    tbb::parallel_for(std::size_t{0}, groups, [&](std::size_t g) { store(g); });
    if (config.neighbour_fusion_radius_m > 0.0) joinNeighbours(config.neighbour_fusion_radius_m);
  }

  // The fused points in key order, joined lone groups left out.
  MergedCloud result() && {
    std::size_t kept = 0;
    for (std::size_t g = 0; g < keys_.size(); ++g) {
      if (target_[g] != kNone) continue;
      cloud_.points[kept] = cloud_.points[g];
      cloud_.covariances[kept] = cloud_.covariances[g];
      cloud_.session[kept] = cloud_.session[g];
      cloud_.session_count[kept] = cloud_.session_count[g];
      cloud_.return_count[kept] = cloud_.return_count[g];
      ++kept;
    }
    cloud_.points.resize(kept);
    cloud_.covariances.resize(kept);
    cloud_.session.resize(kept);
    cloud_.session_count.resize(kept);
    cloud_.return_count.resize(kept);
    cloud_.session_points = members_.size();
    return std::move(cloud_);
  }

 private:
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  static constexpr int kIndexBits = 40;  // a member: session list << 40 | index in it

  const SessionVoxel& member(std::size_t m) const {
    const std::uint64_t ref = members_[m];
    return per_session_[ref >> kIndexBits][ref & ((std::uint64_t{1} << kIndexBits) - 1)];
  }

  // A k-way merge of the sessions' sorted voxel lists: one group per voxel key, its members in
  // session order.
  void groupByVoxel() {
    std::size_t total = 0;
    for (const auto& list : per_session_) total += list.size();
    members_.reserve(total);
    std::vector<std::size_t> cursor(per_session_.size(), 0);
    while (true) {
      std::uint64_t key = kOutOfRange;
      for (std::size_t l = 0; l < per_session_.size(); ++l)
        if (cursor[l] < per_session_[l].size()) key = std::min(key, per_session_[l][cursor[l]].key);
      if (key == kOutOfRange) break;
      starts_.push_back(members_.size());
      keys_.push_back(key);
      for (std::size_t l = 0; l < per_session_.size(); ++l)
        if (cursor[l] < per_session_[l].size() && per_session_[l][cursor[l]].key == key)
          members_.push_back((std::uint64_t{l} << kIndexBits) | cursor[l]++);
    }
    starts_.push_back(members_.size());
  }

  Eigen::Vector3d corner(std::uint64_t key) const {
    const Voxel v = unpackVoxel(key);
    return voxel_m_ * Eigen::Vector3d(static_cast<double>(v[0]), static_cast<double>(v[1]),
                                      static_cast<double>(v[2]));
  }

  // Fuses group g with the lone groups it absorbed and stores the result as point g.
  void store(std::size_t g) {
    Fusion f;
    for (std::size_t m = starts_[g]; m < starts_[g + 1]; ++m)
      f.add(member(m), Eigen::Vector3d::Zero());
    for (std::size_t a = absorbed_head_[g]; a != kNone; a = next_absorbed_[a])
      f.add(member(starts_[a]), corner(keys_[a]) - corner(keys_[g]));
    const Eigen::Matrix3d covariance = f.information.inverse();
    cloud_.points[g] = (corner(keys_[g]) + covariance * f.information_mean).cast<float>();
    cloud_.covariances[g] = covariance.cast<float>();
    cloud_.session[g] = f.best_session;
    cloud_.session_count[g] = f.sessions;
    cloud_.return_count[g] = f.returns;
  }

  bool lone(std::size_t g) const {
    return starts_[g + 1] - starts_[g] == 1 && absorbed_head_[g] == kNone && target_[g] == kNone;
  }

  bool hasSession(std::size_t g, std::uint32_t session) const {
    for (std::size_t m = starts_[g]; m < starts_[g + 1]; ++m)
      if (member(m).session == session) return true;
    for (std::size_t a = absorbed_head_[g]; a != kNone; a = next_absorbed_[a])
      if (member(starts_[a]).session == session) return true;
    return false;
  }

  // The nearest group of another session in the 26 neighbouring voxels whose point lies within
  // `radius` of lone group g's; only voxels within `radius` of g's point are looked up.
  std::size_t nearestNeighbour(std::size_t g, const KeyIndex& index, double radius) const {
    const std::uint32_t session = member(starts_[g]).session;
    const Eigen::Vector3d p = cloud_.points[g].cast<double>();
    const Eigen::Vector3d m = p - corner(keys_[g]);  // position inside the voxel
    const Voxel v = unpackVoxel(keys_[g]);
    std::size_t best = kNone;
    double best2 = radius * radius;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const std::array<int, 3> d{dx, dy, dz};
          double box2 = 0.0;  // squared distance from p to the neighbour voxel
          for (int a = 0; a < 3; ++a) {
            const double gap = d[a] < 0 ? m[a] : d[a] > 0 ? voxel_m_ - m[a] : 0.0;
            box2 += gap > 0.0 ? gap * gap : 0.0;
          }
          if ((dx == 0 && dy == 0 && dz == 0) || box2 >= best2) continue;
          const Voxel n{v[0] + dx, v[1] + dy, v[2] + dz};
          if (!inKeyRange(n)) continue;
          const std::uint32_t h = index.find(packVoxel(n));
          if (h == KeyIndex::kNone || hasSession(h, session)) continue;
          const double dist2 = (cloud_.points[h].cast<double>() - p).squaredNorm();
          if (dist2 < best2) best2 = dist2, best = h;
        }
    return best;
  }

  // Proposals are computed in parallel, then committed in key order and re-checked against
  // what earlier commits changed, so the result does not depend on the thread count.
  void joinNeighbours(double radius) {
    const std::size_t groups = keys_.size();
    const KeyIndex index(keys_);
    std::vector<std::size_t> proposal(groups, kNone);
    tbb::parallel_for(std::size_t{0}, groups, [&](std::size_t g) {
      if (lone(g)) proposal[g] = nearestNeighbour(g, index, radius);
    });
    std::vector<std::size_t> targets;
    for (std::size_t g = 0; g < groups; ++g) {
      const std::size_t h = proposal[g];
      if (h == kNone || !lone(g) || target_[h] != kNone ||
          hasSession(h, member(starts_[g]).session))
        continue;
      if (absorbed_head_[h] == kNone) targets.push_back(h);
      target_[g] = h;
      next_absorbed_[g] = absorbed_head_[h];
      absorbed_head_[h] = g;
    }
    tbb::parallel_for(std::size_t{0}, targets.size(), [&](std::size_t t) { store(targets[t]); });
  }

  std::vector<std::vector<SessionVoxel>> per_session_;  // each in key order
  double voxel_m_;
  std::vector<std::uint64_t> members_;      // references to session voxels, grouped by voxel
  std::vector<std::size_t> starts_;         // group g is members_[starts_[g], starts_[g + 1])
  std::vector<std::uint64_t> keys_;         // voxel of each group, ascending
  std::vector<std::size_t> target_;         // the group a lone group joined, or kNone
  std::vector<std::size_t> absorbed_head_;  // first lone group joined to this one
  std::vector<std::size_t> next_absorbed_;  // next lone group joined to the same one
  MergedCloud cloud_;                       // point g: group g's fused Gaussian
};

}  // namespace

bool MergedCloudConfig::IsValid(std::string* error) const {
  const auto fail = [error](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!std::isfinite(voxel_size_m) || voxel_size_m < 0.005)
    return fail("voxel_size_m must be at least 0.005 (m) and finite");
  if (!std::isfinite(min_range_m) || min_range_m < 0.0)
    return fail("min_range_m must be >= 0 (m) and finite");
  if (!(max_range_m > min_range_m)) return fail("max_range_m must exceed min_range_m");
  if (!std::isfinite(point_sigma_m) || point_sigma_m <= 0.0)
    return fail("point_sigma_m must be > 0 (m) and finite");
  if (!(neighbour_fusion_radius_m >= 0.0 && neighbour_fusion_radius_m <= voxel_size_m))
    return fail("neighbour_fusion_radius_m must be in [0, voxel_size_m]");
  return true;
}

MergedCloud buildMergedCloud(const std::vector<Session>& sessions,
                             const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                             const MergedCloudConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("MergedCloudConfig: " + error);
  checkAtlasPoses(sessions, T_atlas_keyframe, "buildMergedCloud");
  std::vector<std::vector<SessionVoxel>> per_session;
  std::vector<Return> returns;
  std::size_t input_points = 0;
  // Sessions one at a time: only one session's raw returns are held at once.
  for (std::size_t i = 0; i < sessions.size(); ++i) {
    if (!sessions[i].hasScans()) continue;
    sessionReturns(sessions[i], T_atlas_keyframe[i], config, &returns);
    input_points += returns.size();
    per_session.push_back(
        sessionVoxels(&returns, static_cast<std::uint32_t>(i), config.point_sigma_m));
  }
  MergedCloud cloud = Fuser(std::move(per_session), config).result();
  cloud.input_points = input_points;
  return cloud;
}

}  // namespace mm4mm
