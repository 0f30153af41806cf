#include "dfo_core/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/image.h"
#include "dfo_core/lie.h"

namespace dfo {
namespace {

// KITTI odometry sequence 06's P0 intrinsics at its native 1226 x 370.
PinholeCamera KittiCamera() {
  return PinholeCamera(707.0912, 707.0912, 601.8873, 183.1104, 1226, 370);
}

// A set of 3D points in front of the camera, spread over the image.
std::vector<Eigen::Vector3d> TestPoints(const PinholeCamera& cam) {
  std::vector<Eigen::Vector3d> points;
  for (double fu : {0.1, 0.37, 0.5, 0.81, 0.95}) {
    for (double fv : {0.05, 0.5, 0.66, 0.93}) {
      for (double z : {0.5, 4.0, 55.0}) {
        points.push_back(
            cam.Unproject(Eigen::Vector2d(fu * (cam.width - 1), fv * (cam.height - 1)), z));
      }
    }
  }
  return points;
}

// A linear function of continuous pixel coordinates of the full-resolution image.
double Ramp(double u, double v) { return 0.3 * u - 0.7 * v + 11.0; }

// Image whose pixel (x, y) holds Ramp(x, y).
ImageF RampImage(int width, int height) {
  ImageF img(width, height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) img(x, y) = static_cast<float>(Ramp(x, y));
  }
  return img;
}

// Area downsampling by an integer factor k: each output pixel is the mean of a k x k block
// (what a resize of a pixel grid by 1/k does; block centre k i + (k - 1) / 2).
ImageF BlockAverage(const ImageF& img, int k) {
  ImageF out(img.width() / k, img.height() / k);
  for (int y = 0; y < out.height(); ++y) {
    for (int x = 0; x < out.width(); ++x) {
      double sum = 0;
      for (int dy = 0; dy < k; ++dy) {
        for (int dx = 0; dx < k; ++dx) sum += img(k * x + dx, k * y + dy);
      }
      out(x, y) = static_cast<float>(sum / (k * k));
    }
  }
  return out;
}

TEST(Camera, ProjectUnprojectRoundTripDoubleAndFloat) {
  const PinholeCamera cam = KittiCamera();
  for (const Eigen::Vector3d& p : TestPoints(cam)) {
    const Eigen::Vector2d uv = cam.Project(p);
    EXPECT_LT((cam.Unproject(uv, p.z()) - p).norm(), 1e-12 * (1 + p.norm()));
    EXPECT_LT((cam.Ray(uv) * p.z() - p).norm(), 1e-12 * (1 + p.norm()));
    const Eigen::Vector3f pf = p.cast<float>();
    const Eigen::Vector2f uvf = cam.Project(pf);
    EXPECT_LT((uvf.cast<double>() - uv).norm(), 1e-3);
    EXPECT_LT((cam.Unproject(uvf, pf.z()) - pf).norm(), 1e-5f * (1 + pf.norm()));
  }
  // The principal point is the image of the optical axis.
  const Eigen::Vector2d c = cam.Project(Eigen::Vector3d(0, 0, 3));
  EXPECT_DOUBLE_EQ(c.x(), cam.cx);
  EXPECT_DOUBLE_EQ(c.y(), cam.cy);
}

TEST(Camera, ProjectJacobianMatchesFiniteDifferences) {
  const PinholeCamera cam = KittiCamera();
  for (const Eigen::Vector3d& p : TestPoints(cam)) {
    Eigen::Matrix<double, 2, 3> numeric;
    const double h = 1e-6 * (1 + p.norm());
    for (int i = 0; i < 3; ++i) {
      Eigen::Vector3d dp = Eigen::Vector3d::Zero();
      dp(i) = h;
      numeric.col(i) =
          (cam.Project(Eigen::Vector3d(p + dp)) - cam.Project(Eigen::Vector3d(p - dp))) / (2 * h);
    }
    const Eigen::Matrix<double, 2, 3> analytic = cam.ProjectJacobian(p);
    EXPECT_LT((numeric - analytic).norm(), 1e-5 * (1 + analytic.norm())) << p.transpose();
    const Eigen::Matrix<float, 2, 3> analytic_f =
        cam.ProjectJacobian(Eigen::Vector3f(p.cast<float>()));
    EXPECT_LT((analytic_f.cast<double>() - analytic).norm(), 1e-5 * (1 + analytic.norm()));
  }
}

TEST(Camera, PixelJacobianWithRespectToPoseChainsCorrectly) {
  // d pi(Exp(d) T p) / dd = ProjectJacobian(T p) * T.ActionJacobianLeft(p), checked numerically.
  const PinholeCamera cam = KittiCamera();
  Vector6d xi;
  xi << 0.1, -0.05, 0.3, 0.02, -0.04, 0.01;
  const SE3d T = SE3d::Exp(xi);
  const Eigen::Vector3d p(1.0, -0.5, 8.0);
  const Eigen::Matrix<double, 2, 6> analytic =
      cam.ProjectJacobian(Eigen::Vector3d(T * p)) * T.ActionJacobianLeft(p);
  Eigen::Matrix<double, 2, 6> numeric;
  for (int i = 0; i < 6; ++i) {
    Vector6d d = Vector6d::Zero();
    d(i) = 1e-6;
    numeric.col(i) = (cam.Project(Eigen::Vector3d(SE3d::Exp(d) * T * p)) -
                      cam.Project(Eigen::Vector3d(SE3d::Exp(-d) * T * p))) /
                     2e-6;
  }
  EXPECT_LT((numeric - analytic).norm(), 1e-4);
}

TEST(Camera, ResizedCameraProjectsWhereTheResizedImageShowsThePoint) {
  // A 3D point seen at u0 in the full image shows the ramp value Ramp(u0). After area
  // downsampling by k, the resized camera must project the point to the spot of the small image
  // holding that same value (pixel-centre convention; a cx * s mapping would be off by
  // 0.5 (1 - 1/k) pixels, i.e. ramp errors of ~0.1 and more).
  const PinholeCamera cam(500.0, 480.0, 299.5, 151.25, 600, 300);
  const ImageF full = RampImage(cam.width, cam.height);
  for (int k : {2, 3, 4}) {
    const ImageF small = BlockAverage(full, k);
    const PinholeCamera small_cam = cam.Resized(cam.width / k, cam.height / k);
    ASSERT_EQ(small_cam.width, small.width());
    ASSERT_EQ(small_cam.height, small.height());
    EXPECT_DOUBLE_EQ(small_cam.fx, cam.fx / k);
    for (const Eigen::Vector3d& p : TestPoints(cam)) {
      const Eigen::Vector2d u0 = cam.Project(p);
      const Eigen::Vector2d u1 = small_cam.Project(p);
      if (!small_cam.IsInImage(u1)) continue;
      EXPECT_NEAR(small.Bilinear(u1.x(), u1.y()), Ramp(u0.x(), u0.y()), 1e-3) << "k=" << k;
    }
  }
  // Independent axes: width and height scale separately.
  const PinholeCamera net = KittiCamera().Resized(416, 128);
  EXPECT_NEAR(net.fx, 707.0912 * 416.0 / 1226.0, 1e-9);
  EXPECT_NEAR(net.fy, 707.0912 * 128.0 / 370.0, 1e-9);
  EXPECT_EQ(net.width, 416);
  EXPECT_EQ(net.height, 128);
}

TEST(Camera, CroppedCameraMatchesCroppedImage) {
  const PinholeCamera cam(400.0, 400.0, 320.0, 100.0, 640, 200);
  const ImageF full = RampImage(cam.width, cam.height);
  const int x0 = 37, y0 = 21, w = 300, h = 120;
  ImageF crop(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) crop(x, y) = full(x + x0, y + y0);
  }
  const PinholeCamera crop_cam = cam.Cropped(x0, y0, w, h);
  EXPECT_EQ(crop_cam.width, w);
  EXPECT_EQ(crop_cam.height, h);
  int checked = 0;
  for (const Eigen::Vector3d& p : TestPoints(cam)) {
    const Eigen::Vector2d u = cam.Project(p);
    const Eigen::Vector2d uc = crop_cam.Project(p);
    EXPECT_LT((uc - (u - Eigen::Vector2d(x0, y0))).norm(), 1e-9);
    if (!crop_cam.IsInImage(uc)) continue;
    EXPECT_NEAR(crop.Bilinear(uc.x(), uc.y()), full.Bilinear(u.x(), u.y()), 1e-4);
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

TEST(Camera, PyramidLevelIsRepeatedHalvingAndMatchesResizeForEvenSizes) {
  const PinholeCamera cam = KittiCamera().Resized(416, 128);
  const PinholeCamera l0 = cam.PyramidLevel(0);
  EXPECT_EQ(l0.fx, cam.fx);
  EXPECT_EQ(l0.cx, cam.cx);
  const PinholeCamera l2 = cam.PyramidLevel(2);
  const PinholeCamera l1l1 = cam.PyramidLevel(1).PyramidLevel(1);
  EXPECT_DOUBLE_EQ(l2.cx, l1l1.cx);
  EXPECT_DOUBLE_EQ(l2.fy, l1l1.fy);
  // 416x128 halves evenly, so level 3 is the same as resizing to 52x16.
  const PinholeCamera l3 = cam.PyramidLevel(3);
  const PinholeCamera r3 = cam.Resized(52, 16);
  EXPECT_EQ(l3.width, 52);
  EXPECT_EQ(l3.height, 16);
  EXPECT_NEAR(l3.fx, r3.fx, 1e-12);
  EXPECT_NEAR(l3.cx, r3.cx, 1e-12);
  EXPECT_NEAR(l3.cy, r3.cy, 1e-12);
  // Odd sizes: the last column/row is dropped, the mapping u -> (u + 0.5) / 2 - 0.5 stays.
  const PinholeCamera odd(100.0, 100.0, 50.0, 20.0, 101, 41);
  const PinholeCamera odd1 = odd.PyramidLevel(1);
  EXPECT_EQ(odd1.width, 50);
  EXPECT_EQ(odd1.height, 20);
  EXPECT_DOUBLE_EQ(odd1.cx, (50.0 + 0.5) / 2 - 0.5);
  EXPECT_DOUBLE_EQ(odd1.fx, 50.0);
}

// Expects Check() to throw InputError whose message names `field`, and IsValid to agree.
void ExpectInvalid(const PinholeCamera& cam, const std::string& field) {
  std::string why;
  EXPECT_FALSE(cam.IsValid(&why));
  EXPECT_NE(why.find(field), std::string::npos) << why;
  try {
    cam.Check();
    ADD_FAILURE() << "Check() accepted an invalid " << field;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

TEST(Camera, CheckNamesTheOffendingField) {
  EXPECT_NO_THROW(KittiCamera().Check());
  EXPECT_TRUE(KittiCamera().IsValid());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  ExpectInvalid(PinholeCamera(0.0, 700, 600, 180, 1226, 370), "camera.fx");
  ExpectInvalid(PinholeCamera(nan, 700, 600, 180, 1226, 370), "camera.fx");
  ExpectInvalid(PinholeCamera(700, -1.0, 600, 180, 1226, 370), "camera.fy");
  ExpectInvalid(PinholeCamera(700, 700, nan, 180, 1226, 370), "camera.cx");
  ExpectInvalid(PinholeCamera(700, 700, 600, inf, 1226, 370), "camera.cy");
  ExpectInvalid(PinholeCamera(700, 700, 600, 180, 0, 370), "camera.width");
  ExpectInvalid(PinholeCamera(700, 700, 600, 180, 1226, -2), "camera.height");
  EXPECT_FALSE(PinholeCamera().IsValid());
  // Finite but impossible for a pinhole image of this size.
  ExpectInvalid(PinholeCamera(1e300, 700, 600, 180, 1226, 370), "camera.fx = 1e+300 is impossible");
  ExpectInvalid(PinholeCamera(700, 1e-3, 600, 180, 1226, 370), "camera.fy");
  ExpectInvalid(PinholeCamera(700, 100, 600, 180, 1226, 370), "camera.fx / camera.fy");
  // Wide and narrow but possible lenses pass.
  EXPECT_TRUE(PinholeCamera(0.1 * 1226, 0.1 * 370, 600, 180, 1226, 370).IsValid());
  EXPECT_TRUE(PinholeCamera(20 * 1226, 20 * 1226, 600, 180, 1226, 370).IsValid());
}

TEST(Camera, IsInImageHonoursBorder) {
  const PinholeCamera cam(100, 100, 50, 50, 100, 80);
  EXPECT_TRUE(cam.IsInImage(Eigen::Vector2d(0, 0)));
  EXPECT_TRUE(cam.IsInImage(Eigen::Vector2d(99, 79)));
  EXPECT_FALSE(cam.IsInImage(Eigen::Vector2d(99.01, 10)));
  EXPECT_FALSE(cam.IsInImage(Eigen::Vector2d(-0.01, 10)));
  EXPECT_FALSE(cam.IsInImage(Eigen::Vector2d(1.5, 10), 2.0));
  EXPECT_TRUE(cam.IsInImage(Eigen::Vector2d(2.0, 10), 2.0));
}

}  // namespace
}  // namespace dfo
