#include "dfo_core/plane_sweep.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "dfo_core/check_option.h"
#include "dfo_core/error.h"
#include "dfo_core/parallel.h"

namespace dfo {
namespace {

// N summed-area tables of a W x H image, built in one pass: (W + 1) x (H + 1) entries,
// S_c(x, y) = sum of channel c over [0, x) x [0, y).
template <int N>
class SummedAreas {
 public:
  using Sums = std::array<double, N>;
  void Reset(int width, int height) {
    width_ = width;
    sums_.assign(static_cast<size_t>(width + 1) * (height + 1), Sums{});
  }
  // Fills from values(x, y) (the N channels' values at a pixel), row by row.
  template <typename F>
  void Build(int height, F&& values) {
    const int stride = width_ + 1;
    for (int y = 0; y < height; ++y) {
      Sums row{};
      Sums* out = &sums_[static_cast<size_t>(y + 1) * stride + 1];
      const Sums* above = &sums_[static_cast<size_t>(y) * stride + 1];
      for (int x = 0; x < width_; ++x) {
        const Sums v = values(x, y);
        for (int c = 0; c < N; ++c) {
          row[c] += v[c];
          out[x][c] = above[x][c] + row[c];
        }
      }
    }
  }
  // Sums over the window [x - r, x + r] x [y - r, y + r] (inside the image).
  Sums Window(int x, int y, int r) const {
    const int stride = width_ + 1;
    const size_t x0 = x - r, x1 = x + r + 1, y0 = y - r, y1 = y + r + 1;
    const Sums& a = sums_[y1 * stride + x1];
    const Sums& b = sums_[y0 * stride + x1];
    const Sums& c = sums_[y1 * stride + x0];
    const Sums& d = sums_[y0 * stride + x0];
    Sums s;
    for (int k = 0; k < N; ++k) s[k] = a[k] - b[k] - c[k] + d[k];
    return s;
  }

 private:
  int width_ = 0;
  std::vector<Sums> sums_;
};

}  // namespace

void PlaneSweepOptions::Check() const {
  internal::CheckOption(std::isfinite(min_depth_m) && min_depth_m > 0.0, "plane sweep: min_depth_m",
                        min_depth_m, "> 0");
  internal::CheckOption(std::isfinite(max_depth_m) && max_depth_m > min_depth_m,
                        "plane sweep: max_depth_m", max_depth_m, "> min_depth_m");
  internal::CheckOption(num_depths >= 8 && num_depths <= 4096, "plane sweep: num_depths",
                        num_depths, "in [8, 4096]");
  internal::CheckOption(window_radius >= 1 && window_radius <= 16, "plane sweep: window_radius",
                        window_radius, "in [1, 16]");
  internal::CheckOption(std::isfinite(max_cost) && max_cost > 0.0 && max_cost <= 2.0,
                        "plane sweep: max_cost", max_cost, "in (0, 2]");
  internal::CheckOption(std::isfinite(uniqueness) && uniqueness >= 1.0, "plane sweep: uniqueness",
                        uniqueness, ">= 1");
  internal::CheckOption(std::isfinite(min_texture) && min_texture >= 0.0,
                        "plane sweep: min_texture", min_texture, ">= 0");
  internal::CheckOption(std::isfinite(min_epipolar_px) && min_epipolar_px >= 0.0,
                        "plane sweep: min_epipolar_px", min_epipolar_px, ">= 0");
  internal::CheckOption(min_views >= 1, "plane sweep: min_views", min_views, ">= 1");
  internal::CheckOption(num_threads >= 1 && num_threads <= 256, "plane sweep: num_threads",
                        num_threads, "in [1, 256]");
}

PlaneSweepResult PlaneSweepDepth(const ImageF& reference, const PinholeCamera& camera,
                                 const std::vector<StereoView>& views,
                                 const PlaneSweepOptions& options) {
  options.Check();
  const int w = camera.width, h = camera.height;
  const auto check_image = [&](const ImageF* image, const std::string& what) {
    if (image == nullptr) throw InputError("plane sweep: " + what + " has no image");
    if (image->width() != w || image->height() != h || image->channels() != 1) {
      std::ostringstream msg;
      msg << "plane sweep: " << what << " is " << image->width() << "x" << image->height() << "x"
          << image->channels() << ", the camera " << w << "x" << h << "x1";
      throw InputError(msg.str());
    }
  };
  check_image(&reference, "the reference");
  for (size_t v = 0; v < views.size(); ++v)
    check_image(views[v].image, "view " + std::to_string(v));
  if (static_cast<int>(views.size()) < options.min_views) {
    throw InputError("plane sweep: " + std::to_string(views.size()) + " views, min_views " +
                     std::to_string(options.min_views));
  }

  const int r = options.window_radius;
  const double area = (2.0 * r + 1.0) * (2.0 * r + 1.0);
  const size_t n = static_cast<size_t>(w) * h;
  const auto index = [w](int x, int y) { return static_cast<size_t>(y) * w + x; };
  const bool inside_window = w > 2 * r && h > 2 * r;

  // The reference window's mean and standard deviation.
  SummedAreas<2> ref_sums;  // grey level, its square
  ref_sums.Reset(w, h);
  ref_sums.Build(h, [&](int x, int y) {
    const double value = reference(x, y);
    return SummedAreas<2>::Sums{value, value * value};
  });
  std::vector<double> ref_mean(n, 0.0), ref_std(n, 0.0);
  for (int y = r; inside_window && y < h - r; ++y) {
    for (int x = r; x < w - r; ++x) {
      const SummedAreas<2>::Sums window = ref_sums.Window(x, y, r);
      const double m = window[0] / area;
      ref_mean[index(x, y)] = m;
      ref_std[index(x, y)] = std::sqrt(std::max(window[1] / area - m * m, 0.0));
    }
  }

  // Per view: K R ray of every pixel and K t, so that the pixel at inverse depth rho lands on
  // (A + rho B) projected.
  const Eigen::Matrix3d K = camera.K();
  std::vector<std::vector<Eigen::Vector3d>> a(views.size());
  std::vector<Eigen::Vector3d> b(views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    const Eigen::Matrix3d KR = K * views[v].view_from_ref.so3().Matrix();
    b[v] = K * views[v].view_from_ref.translation();
    a[v].resize(n);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        a[v][index(x, y)] = KR * camera.Unproject(Eigen::Vector2d(x, y), 1.0);
      }
    }
  }
  const double rho_min = 1.0 / options.max_depth_m, rho_max = 1.0 / options.min_depth_m;
  const int num_depths = options.num_depths;
  const auto rho_of = [&](double k) {
    return rho_min + (rho_max - rho_min) * k / (num_depths - 1);
  };

  // Longest epipolar segment of the depth range over the views.
  std::vector<float> span(n, 0.0f);
  for (size_t v = 0; v < views.size(); ++v) {
    for (size_t p = 0; p < n; ++p) {
      const Eigen::Vector3d near = a[v][p] + rho_max * b[v], far = a[v][p] + rho_min * b[v];
      if (!(near.z() > 0.0) || !(far.z() > 0.0)) continue;
      const double length = (near.head<2>() / near.z() - far.head<2>() / far.z()).norm();
      if (std::isfinite(length)) span[p] = std::max(span[p], static_cast<float>(length));
    }
  }

  // Only pixels that can get a depth are matched (texture and parallax are known before the
  // sweep), and a view is warped only where their windows need it.
  std::vector<unsigned char> needed(n, 0);
  std::vector<int> wanted_pixels;
  for (int y = r; inside_window && y < h - r; ++y) {
    for (int x = r; x < w - r; ++x) {
      const size_t p = index(x, y);
      if (!(ref_std[p] > 0.0) || ref_std[p] < options.min_texture ||
          span[p] < options.min_epipolar_px) {
        continue;
      }
      wanted_pixels.push_back(static_cast<int>(p));
      for (int dy = -r; dy <= r; ++dy) {
        std::fill_n(&needed[index(x - r, y + dy)], 2 * r + 1, static_cast<unsigned char>(1));
      }
    }
  }
  std::vector<int> needed_pixels;
  for (size_t p = 0; p < n; ++p) {
    if (needed[p]) needed_pixels.push_back(static_cast<int>(p));
  }

  // Cost volume: mean over the views that see the whole window of 1 - ZNCC; +inf below
  // min_views.
  constexpr float kNone = std::numeric_limits<float>::infinity();
  // Only the wanted pixels' costs: cost[k * m + i] for depth k and wanted pixel i.
  const size_t m = wanted_pixels.size();
  std::vector<float> cost(static_cast<size_t>(num_depths) * m, kNone);
  const float* reference_pixels = reference.vector().data();
  // Threads take the depths in turn; each depth's slice is computed alone, so the volume does
  // not depend on who computed it.
  std::atomic<int> next_depth{0};
  const auto sweep = [&]() {
    std::vector<float> warped(n), valid(n), sum(m), count(m);
    // The warped view's grey level w, w^2, w times the reference, and whether it was inside.
    SummedAreas<4> sums;
    sums.Reset(w, h);
    for (int k = next_depth++; k < num_depths; k = next_depth++) {
      const double rho = rho_of(k);
      std::fill(sum.begin(), sum.end(), 0.0f);
      std::fill(count.begin(), count.end(), 0.0f);
      for (size_t v = 0; v < views.size(); ++v) {
        const float* pixels = views[v].image->vector().data();
        std::fill(warped.begin(), warped.end(), 0.0f);
        std::fill(valid.begin(), valid.end(), 0.0f);
        for (const int p : needed_pixels) {
          const Eigen::Vector3d q = a[v][p] + rho * b[v];
          if (!(q.z() > 0.0)) continue;
          const double u = q.x() / q.z(), t = q.y() / q.z();
          if (!(u >= 0.0 && t >= 0.0 && u <= w - 1.0 && t <= h - 1.0)) continue;
          // ImageF::Bilinear's arithmetic, with floor as a cast (u, t >= 0): no libm call.
          const float fu = static_cast<float>(u), ft = static_cast<float>(t);
          const int x0 = static_cast<int>(fu), y0 = static_cast<int>(ft);
          const int x1 = x0 + 1 < w ? x0 + 1 : x0, y1 = y0 + 1 < h ? y0 + 1 : y0;
          const float ax = fu - static_cast<float>(x0), ay = ft - static_cast<float>(y0);
          const float* row0 = pixels + static_cast<size_t>(y0) * w;
          const float* row1 = pixels + static_cast<size_t>(y1) * w;
          warped[p] = (1.0f - ay) * ((1.0f - ax) * row0[x0] + ax * row0[x1]) +
                      ay * ((1.0f - ax) * row1[x0] + ax * row1[x1]);
          valid[p] = 1.0f;
        }
        sums.Build(h, [&](int x, int y) {
          const size_t p = index(x, y);
          const double value = warped[p];
          return SummedAreas<4>::Sums{value, value * value, value * reference_pixels[p],
                                      static_cast<double>(valid[p])};
        });
        for (size_t i = 0; i < m; ++i) {
          const int p = wanted_pixels[i];
          const int x = p % w, y = p / w;
          const SummedAreas<4>::Sums window = sums.Window(x, y, r);
          if (window[3] < area - 0.5) continue;
          const double mean = window[0] / area;
          const double var = window[1] / area - mean * mean;
          if (!(var > 1e-6)) continue;
          const double covariance = window[2] / area - mean * ref_mean[p];
          const double zncc = covariance / (ref_std[p] * std::sqrt(var));
          sum[i] += static_cast<float>(1.0 - std::clamp(zncc, -1.0, 1.0));
          count[i] += 1.0f;
        }
      }
      float* slice = &cost[static_cast<size_t>(k) * m];
      for (size_t i = 0; i < m; ++i) {
        if (count[i] >= options.min_views) slice[i] = sum[i] / count[i];
      }
    }
  };
  RunOnThreads(std::min(options.num_threads, num_depths), [&sweep](int) { sweep(); });

  PlaneSweepResult result;
  result.depth = ImageF(w, h, 1, 0.0f);
  size_t confident = 0;
  // The volume is read depth by depth (rows of m costs, in memory order): the best sample of
  // every pixel, then the lowest other local minimum more than 3 samples from it. Threads take
  // contiguous shares of the pixels, each pixel decided alone.
  const auto row = [&](int k) { return &cost[static_cast<size_t>(k) * m]; };
  std::vector<int> best(m, -1);
  std::vector<float> best_cost(m, kNone);
  std::vector<unsigned char> candidate(m, 0);
  std::vector<double> second(m, kNone);
  float* depth_out = result.depth.vector().data();
  const auto select = [&](size_t begin, size_t end, size_t* confident_out) {
    for (int k = 0; k < num_depths; ++k) {
      const float* c = row(k);
      for (size_t i = begin; i < end; ++i) {
        if (c[i] < kNone && (best[i] < 0 || c[i] < best_cost[i])) {
          best[i] = k;
          best_cost[i] = c[i];
        }
      }
    }
    // Pixels whose best sample is inside the range, good enough, with finite neighbours.
    for (size_t i = begin; i < end; ++i) {
      const int b = best[i];
      if (b <= 0 || b >= num_depths - 1 || !(double(best_cost[i]) <= options.max_cost)) continue;
      candidate[i] = std::isfinite(row(b - 1)[i]) && std::isfinite(row(b + 1)[i]) ? 1 : 0;
    }
    for (int k = 0; k < num_depths; ++k) {
      const float* c = row(k);
      const float* before = k > 0 ? row(k - 1) : nullptr;
      const float* after = k + 1 < num_depths ? row(k + 1) : nullptr;
      for (size_t i = begin; i < end; ++i) {
        if (!candidate[i] || std::abs(k - best[i]) <= 3) continue;
        const bool local_min = (!before || c[i] <= before[i]) && (!after || c[i] <= after[i]);
        if (local_min) second[i] = std::min(second[i], double(c[i]));
      }
    }
    size_t count = 0;
    for (size_t i = begin; i < end; ++i) {
      if (!candidate[i]) continue;
      const double c_best = best_cost[i];
      const double c_left = row(best[i] - 1)[i], c_right = row(best[i] + 1)[i];
      if (!(second[i] >= options.uniqueness * c_best)) continue;
      const double curvature = c_left - 2.0 * c_best + c_right;
      const double offset =
          curvature > 0.0 ? std::clamp(0.5 * (c_left - c_right) / curvature, -0.5, 0.5) : 0.0;
      const double rho = rho_of(best[i] + offset);
      if (!(rho > 0.0)) continue;
      depth_out[wanted_pixels[i]] = static_cast<float>(1.0 / rho);
      ++count;
    }
    *confident_out = count;
  };
  const size_t select_threads =
      std::max<size_t>(1, std::min<size_t>(static_cast<size_t>(options.num_threads), m / 1024));
  std::vector<size_t> confident_of(select_threads, 0);
  RunOnThreads(static_cast<int>(select_threads), [&](int t) {
    select(m * t / select_threads, m * (t + 1) / select_threads, &confident_of[t]);
  });
  for (size_t c : confident_of) confident += c;
  result.confident_fraction = n > 0 ? static_cast<double>(confident) / n : 0.0;
  return result;
}

}  // namespace dfo
