#include "dfo_io/lens.h"

#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dfo_core/error.h"

namespace dfo::io {
namespace {

// cv::Mat headers over dfo images (no copy; the image keeps the pixels).
template <typename T>
cv::Mat Wrap(const Image<T>& image, int depth) {
  return cv::Mat(image.height(), image.width(), CV_MAKETYPE(depth, image.channels()),
                 const_cast<T*>(image.data()));
}

}  // namespace

const char* LensModelName(LensModel model) {
  switch (model) {
    case LensModel::kPinhole:
      return "pinhole";
    case LensModel::kRadtan:
      return "radtan";
    case LensModel::kEquidistant:
      return "equidistant";
  }
  return "unknown";
}

bool LensDistortion::IsIdentity() const {
  if (model == LensModel::kPinhole) return true;
  return model == LensModel::kRadtan && k1 == 0.0 && k2 == 0.0 && k3 == 0.0 && p1 == 0.0 &&
         p2 == 0.0;
}

// Float maps (CV_32FC1): remap converts them to its fixed-point form block by block, so bilinear
// results equal those of precomputed CV_16SC2 maps, and nearest-neighbour lookups (depth) round
// instead of truncating as they would with the fixed-point maps' integer part.
struct Undistorter::Maps {
  cv::Mat x;
  cv::Mat y;
};

Undistorter::Undistorter(const PinholeCamera& camera, const LensDistortion& lens,
                         const std::string& what)
    : camera_(camera), lens_(lens), maps_(std::make_unique<Maps>()) {
  camera_.Check();
  cv::Mat k = cv::Mat::eye(3, 3, CV_64F);
  k.at<double>(0, 0) = camera.fx;
  k.at<double>(1, 1) = camera.fy;
  k.at<double>(0, 2) = camera.cx;
  k.at<double>(1, 2) = camera.cy;
  const cv::Size size(camera.width, camera.height);
  const cv::Mat rotation = cv::Mat::eye(3, 3, CV_64F);
  try {
    if (lens.model == LensModel::kEquidistant) {
      const cv::Mat d = (cv::Mat_<double>(4, 1) << lens.k1, lens.k2, lens.k3, lens.k4);
      // New camera matrix = K: the pinhole camera with the distorted camera's intrinsics.
      cv::fisheye::initUndistortRectifyMap(k, d, rotation, k, size, CV_32FC1, maps_->x, maps_->y);
    } else {
      const cv::Mat d = (cv::Mat_<double>(5, 1) << lens.k1, lens.k2, lens.p1, lens.p2, lens.k3);
      cv::initUndistortRectifyMap(k, d, rotation, k, size, CV_32FC1, maps_->x, maps_->y);
    }
  } catch (const cv::Exception& e) {
    throw InputError(what + ": cannot compute the undistortion maps of lens model '" +
                     LensModelName(lens.model) + "': " + e.what());
  }
  // An output pixel has a source pixel when its bilinear footprint lies inside the image.
  const float max_x = static_cast<float>(camera.width - 1);
  const float max_y = static_cast<float>(camera.height - 1);
  size_t empty = 0;
  for (int v = 0; v < camera.height; ++v) {
    const float* mx = maps_->x.ptr<float>(v);
    const float* my = maps_->y.ptr<float>(v);
    for (int u = 0; u < camera.width; ++u) {
      // Negated comparisons count NaN as empty too.
      if (!(mx[u] >= 0.0f && mx[u] <= max_x && my[u] >= 0.0f && my[u] <= max_y)) ++empty;
    }
  }
  empty_fraction_ =
      static_cast<double>(empty) / (static_cast<double>(camera.width) * camera.height);
  if (empty_fraction_ > 0.5) {
    char buf[512];
    std::snprintf(buf, sizeof(buf),
                  ": undistortion of lens model '%s' (k1 %g, k2 %g, k3 %g, k4 %g, p1 %g, p2 %g) "
                  "to the pinhole camera with the same fx, fy, cx, cy would leave %.0f %% of the "
                  "%dx%d output image empty (those pixels map outside the source image; more than "
                  "50 %% is refused): check the coefficients and the model",
                  LensModelName(lens.model), lens.k1, lens.k2, lens.k3, lens.k4, lens.p1, lens.p2,
                  100.0 * empty_fraction_, camera.width, camera.height);
    throw InputError(what + buf);
  }
}

Undistorter::~Undistorter() = default;

ImageU8 Undistorter::Apply(const ImageU8& distorted) const {
  DFO_CHECK(distorted.width() == camera_.width && distorted.height() == camera_.height)
      << distorted.width() << "x" << distorted.height() << " vs " << camera_.width << "x"
      << camera_.height;
  DFO_CHECK(distorted.channels() == 1 || distorted.channels() == 3) << distorted.channels();
  ImageU8 out(camera_.width, camera_.height, distorted.channels());
  cv::Mat dst = Wrap(out, CV_8U);
  cv::remap(Wrap(distorted, CV_8U), dst, maps_->x, maps_->y, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar::all(0));
  DFO_CHECK(dst.ptr<void>() == static_cast<void*>(out.data())) << "remap reallocated its output";
  return out;
}

ImageF Undistorter::ApplyDepth(const ImageF& distorted) const {
  DFO_CHECK(distorted.width() == camera_.width && distorted.height() == camera_.height)
      << distorted.width() << "x" << distorted.height() << " vs " << camera_.width << "x"
      << camera_.height;
  DFO_CHECK(distorted.channels() == 1) << distorted.channels();
  ImageF out(camera_.width, camera_.height, 1);
  cv::Mat dst = Wrap(out, CV_32F);
  cv::remap(Wrap(distorted, CV_32F), dst, maps_->x, maps_->y, cv::INTER_NEAREST,
            cv::BORDER_CONSTANT, cv::Scalar::all(0));
  DFO_CHECK(dst.ptr<void>() == static_cast<void*>(out.data())) << "remap reallocated its output";
  return out;
}

Eigen::Vector2d Undistorter::SourcePixel(int u, int v) const {
  DFO_CHECK(u >= 0 && v >= 0 && u < camera_.width && v < camera_.height) << u << ", " << v;
  return Eigen::Vector2d(maps_->x.at<float>(v, u), maps_->y.at<float>(v, u));
}

std::shared_ptr<const Undistorter> MakeUndistorter(const PinholeCamera& camera,
                                                   const LensDistortion& lens,
                                                   const std::string& what) {
  if (lens.IsIdentity()) return nullptr;
  return std::make_shared<const Undistorter>(camera, lens, what);
}

}  // namespace dfo::io
