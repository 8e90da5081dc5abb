#include "mm4mm/magnetic/correlation_search.hpp"

#include <fftw3.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstring>
#include <memory>
#include <mutex>
#include <stdexcept>

#include "mm4mm/core/pose.hpp"

namespace mm4mm {
namespace {

constexpr int kMaxChannels = 3;

// FFTW wants its own allocation for SIMD alignment; plans made on one buffer run on any other
// buffer allocated the same way. A buffer an FFT writes whole is left unset: zeroing a canvas-sized
// buffer only to overwrite it cost as much as the transforms (issue 33's profile).
enum class Fill { kZero, kNone };

template <typename T>
struct FftwBuffer {
  explicit FftwBuffer(std::size_t n, Fill fill = Fill::kZero)
      : data(static_cast<T*>(fftw_malloc(n * sizeof(T))), &fftw_free), size(n) {
    if (!data) throw std::bad_alloc();
    if (fill == Fill::kZero) std::fill(data.get(), data.get() + n, T{});
  }
  T* get() const { return data.get(); }
  std::unique_ptr<T, decltype(&fftw_free)> data;
  std::size_t size;
};
using RealBuffer = FftwBuffer<double>;
using ComplexBuffer = FftwBuffer<std::complex<double>>;

fftw_complex* asFftw(const ComplexBuffer& b) { return reinterpret_cast<fftw_complex*>(b.get()); }

int goodFftSize(int n) {
  for (int m = std::max(n, 1);; ++m) {
    int r = m;
    for (int f : {2, 3, 5, 7})
      while (r % f == 0) r /= f;
    if (r == 1) return m;
  }
}

// FFTW's planner is not thread-safe; plan creation and destruction take this lock.
std::mutex fftw_planner_mutex;

// Plans are created once per search and executed concurrently on per-thread buffers
// (fftw_execute_dft_* is thread-safe).
class FftPlans {
 public:
  FftPlans(int nx, int ny) : nx_(nx), ny_(ny) {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex);
    RealBuffer real(realSize());
    ComplexBuffer spectrum(spectrumSize());
    forward_ = fftw_plan_dft_r2c_2d(ny, nx, real.get(), asFftw(spectrum), FFTW_ESTIMATE);
    inverse_ = fftw_plan_dft_c2r_2d(ny, nx, asFftw(spectrum), real.get(), FFTW_ESTIMATE);
  }
  ~FftPlans() {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex);
    fftw_destroy_plan(forward_);
    fftw_destroy_plan(inverse_);
  }
  FftPlans(const FftPlans&) = delete;
  FftPlans& operator=(const FftPlans&) = delete;

  std::size_t realSize() const { return static_cast<std::size_t>(nx_) * ny_; }
  std::size_t spectrumSize() const { return static_cast<std::size_t>(nx_ / 2 + 1) * ny_; }
  void forward(const RealBuffer& in, const ComplexBuffer& out) const {
    fftw_execute_dft_r2c(forward_, in.get(), asFftw(out));
  }
  // Destroys `in`, as FFTW's multi-dimensional c2r transforms do.
  void inverse(const ComplexBuffer& in, const RealBuffer& out) const {
    fftw_execute_dft_c2r(inverse_, asFftw(in), out.get());
  }
  int nx() const { return nx_; }
  int ny() const { return ny_; }

 private:
  int nx_, ny_;
  fftw_plan forward_ = nullptr;
  fftw_plan inverse_ = nullptr;
};

// A map laid onto a zero-padded canvas: mask, channel values and their squared sum, each
// multiplied by the mask, ready for correlation.
struct Canvas {
  int channels = 0;
  std::vector<RealBuffer> layers;  // mask, channel 0 .. n-1, sum of squares
  explicit Canvas(const FftPlans& plans, int n) : channels(n) {
    for (int i = 0; i < n + 2; ++i) layers.emplace_back(plans.realSize());
  }
  // Zeroes the top-left `side` x `side` cells, the only ones set() has written since the canvas
  // was made (the rest is padding that stays zero).
  void clear(const FftPlans& plans, int side) {
    for (auto& l : layers)
      for (int v = 0; v < side; ++v)
        std::fill_n(l.get() + static_cast<std::size_t>(v) * plans.nx(), side, 0.0);
  }
  void set(const FftPlans& plans, int ix, int iy, const double* values) {
    const std::size_t i = static_cast<std::size_t>(iy) * plans.nx() + ix;
    layers[0].get()[i] = 1.0;
    double squares = 0.0;
    for (int c = 0; c < channels; ++c)
      layers[1 + c].get()[i] = values[c], squares += values[c] * values[c];
    layers[channels + 1].get()[i] = squares;
  }
};

std::vector<ComplexBuffer> spectraBuffers(const FftPlans& plans, int count) {
  std::vector<ComplexBuffer> spectra;
  for (int i = 0; i < count; ++i) spectra.emplace_back(plans.spectrumSize(), Fill::kNone);
  return spectra;
}

void transform(const FftPlans& plans, const Canvas& canvas, std::vector<ComplexBuffer>* spectra) {
  for (std::size_t i = 0; i < canvas.layers.size(); ++i)
    plans.forward(canvas.layers[i], (*spectra)[i]);
}

// result = sum over pairs of x · conj(y), the spectrum of the correlation sum_u x(u + d) y(u).
void correlate(const std::vector<std::pair<const ComplexBuffer*, const ComplexBuffer*>>& pairs,
               const ComplexBuffer& product, const RealBuffer& result, const FftPlans& plans) {
  std::complex<double>* p = product.get();
  const std::complex<double>* x0 = pairs.front().first->get();
  const std::complex<double>* y0 = pairs.front().second->get();
  for (std::size_t i = 0; i < product.size; ++i) p[i] = x0[i] * std::conj(y0[i]);
  for (std::size_t k = 1; k < pairs.size(); ++k) {
    const std::complex<double>* x = pairs[k].first->get();
    const std::complex<double>* y = pairs[k].second->get();
    for (std::size_t i = 0; i < product.size; ++i) p[i] += x[i] * std::conj(y[i]);
  }
  plans.inverse(product, result);
}

// What one thread needs for a yaw, made once per search and thread: nothing is allocated per yaw.
struct YawWork {
  Canvas b;
  std::vector<ComplexBuffer> spectra;  // of b's layers
  std::vector<RealBuffer> sums;        // N, SA..., SA2, SB..., SB2, SAB
  ComplexBuffer product;
  std::vector<double> z;
  YawWork(const FftPlans& plans, int channels)
      : b(plans, channels),
        spectra(spectraBuffers(plans, channels + 2)),
        product(plans.spectrumSize(), Fill::kNone),
        z(plans.realSize()) {
    for (int i = 0; i < 2 * channels + 4; ++i) sums.emplace_back(plans.realSize(), Fill::kNone);
  }
};

bool distinct(const CorrelationMode& a, const CorrelationMode& b,
              const CorrelationSearchConfig& c) {
  return translationDistance(a.T_a_b, b.T_a_b) > c.mode_separation_m ||
         yawDistance(a.T_a_b, b.T_a_b) > c.mode_separation_deg * M_PI / 180.0;
}

// The yaws a search covers (radians): the full circle, or a window about a centre.
std::vector<double> yawSteps(const CorrelationSearchConfig& config) {
  const double step = config.yaw_step_deg * M_PI / 180.0;
  const int half_steps =
      static_cast<int>(std::floor(config.yaw_window_deg / config.yaw_step_deg + 1e-9));
  const bool full_circle = config.yaw_window_deg >= 180.0;
  const int count =
      full_circle ? static_cast<int>(std::round(360.0 / config.yaw_step_deg)) : 2 * half_steps + 1;
  const double first = full_circle ? 0.0 : config.yaw_centre_deg * M_PI / 180.0 - half_steps * step;
  std::vector<double> yaws(count);
  for (int k = 0; k < count; ++k) yaws[k] = wrapAngle(first + k * step);
  return yaws;
}

std::uint64_t yawKey(double yaw) {
  std::uint64_t bits;
  std::memcpy(&bits, &yaw, sizeof bits);
  return bits;
}

// The sweep: for each of `yaws`, z at every shift by FFT; the distinct modes among the local
// maxima. Yaws `memo` holds are taken from it; those swept are added to it.
std::vector<CorrelationMode> sweep(const MagneticMap& a, const MagneticMap& b,
                                   const CorrelationSearchConfig& config,
                                   const std::vector<double>& all_yaws, SweepMemo* memo) {
  std::vector<double> yaws;
  for (const double yaw : all_yaws)
    if (!memo || !memo->per_yaw.count(yawKey(yaw))) yaws.push_back(yaw);
  // Every yaw's modes in all_yaws' order, as if all were swept now: the final ranking sorts
  // them, and ties keep the order they come in.
  const auto gathered = [&](std::vector<std::vector<CorrelationMode>>&& swept) {
    std::vector<CorrelationMode> all;
    std::size_t next = 0;
    for (const double yaw : all_yaws) {
      if (next < yaws.size() && yawKey(yaws[next]) == yawKey(yaw)) {
        if (memo) memo->per_yaw[yawKey(yaw)] = swept[next];
        all.insert(all.end(), swept[next].begin(), swept[next].end());
        ++next;
      } else {
        const std::vector<CorrelationMode>& kept = memo->per_yaw.at(yawKey(yaw));
        all.insert(all.end(), kept.begin(), kept.end());
      }
    }
    return distinctModes(std::move(all), config);
  };
  if (yaws.empty()) return gathered({});
  const double cell = a.cell_size_m;
  const int channels = channelCount(config.channels);
  // B is rotated about its centre onto a square canvas large enough for any yaw.
  const Eigen::Vector2d b_size(b.width * cell, b.height * cell);
  const Eigen::Vector2d b_centre = b.origin_m + 0.5 * b_size;
  const int side = static_cast<int>(std::ceil(b_size.norm() / cell)) + 2;
  const FftPlans plans(goodFftSize(a.width + side), goodFftSize(a.height + side));

  Canvas a_canvas(plans, channels);
  double a_values[kMaxChannels];
  for (int iy = 0; iy < a.height; ++iy)
    for (int ix = 0; ix < a.width; ++ix)
      if (a.covered(ix, iy)) {
        channelValues(a, a.index(ix, iy), config.channels, 0.0, a_values);
        a_canvas.set(plans, ix, iy, a_values);
      }
  std::vector<ComplexBuffer> fa = spectraBuffers(plans, channels + 2);
  transform(plans, a_canvas, &fa);

  const double min_cells = config.min_overlap_m2 / (cell * cell);
  const double norm = 1.0 / static_cast<double>(plans.realSize());

  tbb::enumerable_thread_specific<std::unique_ptr<YawWork>> work;
  std::vector<std::vector<CorrelationMode>> per_yaw(yaws.size());
  tbb::parallel_for(std::size_t{0}, yaws.size(), [&](std::size_t k) {
    auto& w = work.local();
    if (!w) w = std::make_unique<YawWork>(plans, channels);
    const double yaw = yaws[k];
    const Eigen::Rotation2Dd R(yaw);
    const Eigen::Vector2d canvas_origin =
        R * b_centre - 0.5 * side * cell * Eigen::Vector2d::Ones();
    w->b.clear(plans, side);
    // Per yaw, not shared: the yaws run concurrently.
    double b_values[kMaxChannels];
    for (int v = 0; v < side; ++v)
      for (int u = 0; u < side; ++u) {
        const Eigen::Vector2d p_b =
            R.inverse() * (canvas_origin + cell * Eigen::Vector2d(u + 0.5, v + 0.5));
        const Eigen::Vector2d c = (p_b - b.origin_m) / cell;
        const int ix = static_cast<int>(std::floor(c.x())),
                  iy = static_cast<int>(std::floor(c.y()));
        if (!b.covered(ix, iy)) continue;
        channelValues(b, b.index(ix, iy), config.channels, yaw, b_values);
        w->b.set(plans, u, v, b_values);
      }
    transform(plans, w->b, &w->spectra);
    const std::vector<ComplexBuffer>& fb = w->spectra;
    // Sums over the overlap for every shift d, where a's cell u + d meets b's cell u.
    correlate({{&fa[0], &fb[0]}}, w->product, w->sums[0], plans);
    for (int c = 0; c <= channels; ++c)
      correlate({{&fa[1 + c], &fb[0]}}, w->product, w->sums[1 + c], plans);
    for (int c = 0; c <= channels; ++c)
      correlate({{&fa[0], &fb[1 + c]}}, w->product, w->sums[channels + 2 + c], plans);
    std::vector<std::pair<const ComplexBuffer*, const ComplexBuffer*>> cross;
    for (int c = 0; c < channels; ++c) cross.push_back({&fa[1 + c], &fb[1 + c]});
    correlate(cross, w->product, w->sums[2 * channels + 3], plans);

    const int nx = plans.nx(), ny = plans.ny();
    std::vector<double>& z = w->z;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const std::size_t at = static_cast<std::size_t>(j) * nx + i;
        z[at] = -1e9;
        const double n = std::round(w->sums[0].get()[at] * norm);
        if (n < min_cells) continue;
        double cov = w->sums[2 * channels + 3].get()[at] * norm;
        double var_a = w->sums[channels + 1].get()[at] * norm;
        double var_b = w->sums[2 * channels + 2].get()[at] * norm;
        double mean_difference_squared = 0.0;
        for (int c = 0; c < channels; ++c) {
          const double sa = w->sums[1 + c].get()[at] * norm;
          const double sb = w->sums[channels + 2 + c].get()[at] * norm;
          cov -= sa * sb / n;
          var_a -= sa * sa / n;
          var_b -= sb * sb / n;
          mean_difference_squared += (sa - sb) * (sa - sb) / (n * n);
        }
        if (var_a <= 1e-9 * n || var_b <= 1e-9 * n) continue;
        const double r =
            correlationOf(config.statistic, cov, var_a, var_b, mean_difference_squared, n);
        z[at] = correlationZ(r, n * cell * cell / config.area_per_sample_m2);
      }
    // Local maxima over the 8-neighbourhood of shifts become candidates.
    std::vector<CorrelationMode> candidates;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const double here = z[static_cast<std::size_t>(j) * nx + i];
        if (here <= 0.0) continue;
        bool peak = true;
        for (int dj = -1; dj <= 1 && peak; ++dj)
          for (int di = -1; di <= 1 && peak; ++di)
            if ((di || dj) &&
                z[static_cast<std::size_t>((j + dj + ny) % ny) * nx + (i + di + nx) % nx] > here)
              peak = false;
        if (!peak) continue;
        // Shift indices wrap: large ones are negative shifts.
        const int dx = i < a.width ? i : i - nx;
        const int dy = j < a.height ? j : j - ny;
        const Eigen::Vector2d t = a.origin_m - canvas_origin + cell * Eigen::Vector2d(dx, dy);
        const std::size_t at = static_cast<std::size_t>(j) * nx + i;
        const double n = std::round(w->sums[0].get()[at] * norm);
        const double overlap = n * cell * cell;
        candidates.push_back(
            {{t.x(), t.y(), yaw}, here, std::tanh(here / std::sqrt(overlap - 3.0)), overlap});
      }
    per_yaw[k] = distinctModes(std::move(candidates), config);
  });

  return gathered(std::move(per_yaw));
}

}  // namespace

const char* sampleCountProblem(double min_overlap_m2, double area_per_sample_m2) {
  if (!(area_per_sample_m2 > 0.0)) return "area_per_sample_m2 must be > 0";
  if (!(min_overlap_m2 > 3.0 * area_per_sample_m2))
    return "min_overlap_m2 must be > 3 area_per_sample_m2 (z needs more than 3 samples)";
  return nullptr;
}

double correlationZ(double r, double samples) {
  if (samples <= 3.0) return 0.0;
  const double clamped = std::clamp(r, -0.999999, 0.999999);
  return std::atanh(clamped) * std::sqrt(samples - 3.0);
}

std::vector<CorrelationMode> distinctModes(std::vector<CorrelationMode> candidates,
                                           const CorrelationSearchConfig& config) {
  std::sort(candidates.begin(), candidates.end(), [&](const auto& x, const auto& y) {
    const auto credible = [&](const CorrelationMode& m) {
      return m.r >= config.credible_r && m.overlap_m2 >= config.credible_min_overlap_m2;
    };
    const bool x_credible = credible(x), y_credible = credible(y);
    if (x_credible != y_credible) return x_credible;
    return x.z > y.z;
  });
  std::vector<CorrelationMode> modes;
  for (const auto& c : candidates) {
    if (static_cast<int>(modes.size()) >= config.max_modes) break;
    if (std::all_of(modes.begin(), modes.end(),
                    [&](const auto& m) { return distinct(c, m, config); }))
      modes.push_back(c);
  }
  return modes;
}

bool CorrelationSearchConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (!(yaw_step_deg > 0.0 && yaw_step_deg <= 90.0)) return fail("yaw_step_deg must be in (0, 90]");
  if (const char* problem = sampleCountProblem(min_overlap_m2, area_per_sample_m2))
    return fail(problem);
  if (!(yaw_window_deg > 0.0 && yaw_window_deg <= 180.0))
    return fail("yaw_window_deg must be in (0, 180]");
  if (max_modes < 1) return fail("max_modes must be >= 1");
  if (!(credible_r > -1.0 && credible_r <= 1.0)) return fail("credible_r must be in (-1, 1]");
  if (!(credible_min_overlap_m2 >= 0.0)) return fail("credible_min_overlap_m2 must be >= 0");
  if (!(mode_separation_m > 0.0) || !(mode_separation_deg > 0.0))
    return fail("mode_separation_m and mode_separation_deg must be > 0");
  if (pyramid_factor < 1 || pyramid_factor > 8) return fail("pyramid_factor must be in [1, 8]");
  if (pyramid_candidates < 1) return fail("pyramid_candidates must be >= 1");
  if (pyramid_yaws < 1) return fail("pyramid_yaws must be >= 1");
  return true;
}

std::vector<CorrelationMode> correlationSearch(const MagneticMap& a, const MagneticMap& b,
                                               const CorrelationSearchConfig& config,
                                               SweepMemo* memo) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("correlation search: " + error);
  if (std::abs(a.cell_size_m - b.cell_size_m) > 1e-9)
    throw std::invalid_argument("correlation search needs maps of one cell size");
  if (a.coveredCells() == 0 || b.coveredCells() == 0) return {};
  const std::vector<double> yaws = yawSteps(config);
  if (config.pyramid_factor == 1) return sweep(a, b, config, yaws, memo);

  // Coarse: the sweep on coarser maps, with yaw steps as many times coarser (a yaw step moves a
  // cell at a given distance from the centre by a fixed share of a cell), keeping more peaks,
  // closer together, than the answer will hold.
  CorrelationSearchConfig coarse = config;
  coarse.max_modes = config.pyramid_candidates;
  // Ranked credible first, as the answer's modes are, but a coarse peak counts as credible only
  // with as many cells as the fine search's smallest overlap: on coarse cells an overlap near the
  // minimum holds a quarter of them and its r reaches credible_r by chance, and such peaks took
  // every yaw in held-out hallway seed 2006. Ranked by z alone instead, large mediocre overlaps
  // took them in the warehouse (3 of 4 one-sensor pairs of tuning seed 1 lost; docs/benchmarks.md).
  coarse.credible_min_overlap_m2 =
      std::max(config.credible_min_overlap_m2,
               config.min_overlap_m2 * config.pyramid_factor * config.pyramid_factor);
  coarse.yaw_step_deg = std::min(90.0, config.yaw_step_deg * config.pyramid_factor);
  coarse.mode_separation_m = config.pyramid_factor * a.cell_size_m;
  coarse.mode_separation_deg = coarse.yaw_step_deg;
  const std::vector<CorrelationMode> peaks =
      sweep(downsample(a, config.pyramid_factor), downsample(b, config.pyramid_factor), coarse,
            yawSteps(coarse), nullptr);
  if (peaks.empty()) return {};

  // Fine: the full sweep of every shift, at the search's own yaws within half a coarse step of
  // the peaks' (the yaws of the pyramid_yaws best-ranked peaks' distinct yaws).
  const double reach = 0.5 * coarse.yaw_step_deg * M_PI / 180.0 + 1e-9;
  std::vector<double> peak_yaws;
  for (const CorrelationMode& peak : peaks) {
    const double yaw = peak.T_a_b.yaw_rad;
    if (std::any_of(peak_yaws.begin(), peak_yaws.end(),
                    [&](double y) { return std::abs(wrapAngle(y - yaw)) < 1e-9; }))
      continue;
    if (static_cast<int>(peak_yaws.size()) == config.pyramid_yaws) break;
    peak_yaws.push_back(yaw);
  }
  std::vector<double> fine;
  for (const double yaw : yaws)
    if (std::any_of(peak_yaws.begin(), peak_yaws.end(),
                    [&](double y) { return std::abs(wrapAngle(y - yaw)) <= reach; }))
      fine.push_back(yaw);
  return sweep(a, b, config, fine, memo);
}

}  // namespace mm4mm
