#pragma once
// Nearest neighbours among 3-D points (internal): FLANN's single kd-tree, queried one point at a
// time. PCL's KdTreeFLANN wraps every query in an OpenMP parallel region (FLANN's batch search);
// called from TBB tasks, opening those regions costs more than the searches themselves, so the
// point maps and ICP-EM query the index directly. Deterministic: the tree and its answers depend
// only on the points.

#include <flann/algorithms/dist.h>
#include <flann/algorithms/kdtree_single_index.h>
#include <flann/util/result_set.h>

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <vector>

namespace mm4mm {

class KdTree3f {
 public:
  /// Indexes a copy of `points` (m); the vector may change or go afterwards.
  explicit KdTree3f(const std::vector<Eigen::Vector3f>& points) : size_(points.size()) {
    if (points.empty()) return;
    // Vector3f has no padding, so the points are an n x 3 row-major float matrix; FLANN copies
    // them (reorder) when it builds the tree.
    const flann::Matrix<float> data(const_cast<float*>(points.front().data()), points.size(), 3);
    index_ = std::make_unique<Index>(data, flann::KDTreeSingleIndexParams(15));
    index_->buildIndex();
  }

  std::size_t size() const { return size_; }

  /// The up to `k` points nearest to `query`, nearest first: their indices into the points given
  /// to the constructor and squared distances (m²). Returns how many were found. Thread-safe.
  std::size_t nearest(const Eigen::Vector3f& query, std::size_t k, std::size_t* indices,
                      float* distances2) const {
    if (!index_ || k == 0) return 0;
    flann::KNNSimpleResultSet<float> result(k);
    index_->findNeighbors(result, query.data(), flann::SearchParams(-1, 0.0f));
    const std::size_t found = result.size();
    result.copy(indices, distances2, found);
    return found;
  }

 private:
  using Index = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;
  std::size_t size_ = 0;
  std::unique_ptr<Index> index_;
};

}  // namespace mm4mm
