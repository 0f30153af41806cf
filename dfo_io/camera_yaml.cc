#include "dfo_io/camera_yaml.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_io/file_reader.h"
#include "dfo_io/config.h"
#include "dfo_io/dataset.h"

namespace dfo::io {
namespace fs = std::filesystem;
namespace {

std::string At(const std::string& path, const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? path : path + ":" + std::to_string(mark.line + 1);
}

double ToNumber(const std::string& path, const std::string& key, const YAML::Node& node) {
  const std::string text = node.IsScalar() ? node.Scalar() : std::string();
  char* end = nullptr;
  const double v = text.empty() ? 0.0 : std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw InputError(At(path, node) + ": camera key '" + key + "': expected a number, found " +
                     (node.IsScalar() ? "'" + text + "'" : std::string("no scalar value")));
  }
  return v;
}

int ToInt(const std::string& path, const std::string& key, const YAML::Node& node) {
  const double v = ToNumber(path, key, node);
  if (v != std::floor(v) || v < 1 || v > 1e6) {
    throw InputError(At(path, node) + ": camera key '" + key +
                     "': expected a positive whole number of pixels, found '" + node.Scalar() +
                     "'");
  }
  return static_cast<int>(v);
}

// The lens model and its coefficients (see the header): each model takes exactly its own keys.
LensDistortion ReadLens(const std::string& path, const YAML::Node& root) {
  LensDistortion lens;
  std::string model = "pinhole";
  if (root["model"]) {
    model = root["model"].IsScalar() ? root["model"].Scalar() : "";
    if (model == "radtan") {
      lens.model = LensModel::kRadtan;
    } else if (model == "equidistant") {
      lens.model = LensModel::kEquidistant;
    } else if (model != "pinhole") {
      throw InputError(At(path, root["model"]) + ": camera key 'model': '" + model +
                       "' is not a known lens model, expected one of pinhole, radtan, "
                       "equidistant");
    }
  }
  struct Coefficient {
    const char* key;
    double* value;
    bool radtan;       // key of radtan (all required but k3)
    bool equidistant;  // key of equidistant (all required)
  };
  const Coefficient coefficients[] = {{"k1", &lens.k1, true, true},  {"k2", &lens.k2, true, true},
                                      {"k3", &lens.k3, true, true},  {"k4", &lens.k4, false, true},
                                      {"p1", &lens.p1, true, false}, {"p2", &lens.p2, true, false}};
  const char* expected = lens.model == LensModel::kRadtan        ? "k1 k2 p1 p2, optional k3"
                         : lens.model == LensModel::kEquidistant ? "k1 k2 k3 k4"
                                                                 : "none";
  const std::string model_at = root["model"] ? At(path, root["model"]) : path;
  for (const Coefficient& c : coefficients) {
    const bool belongs = lens.model == LensModel::kRadtan        ? c.radtan
                         : lens.model == LensModel::kEquidistant ? c.equidistant
                                                                 : false;
    const YAML::Node node = root[c.key];
    if (node && !belongs) {
      throw InputError(At(path, node) + ": camera key '" + c.key +
                       "' is not a coefficient of lens model '" + model +
                       "' (its keys: " + expected +
                       "); set 'model: radtan' (k1 k2 p1 p2 k3) or 'model: "
                       "equidistant' (k1 k2 k3 k4)");
    }
    if (!belongs) continue;
    if (!node) {
      if (lens.model == LensModel::kRadtan && std::string(c.key) == "k3") continue;  // optional
      throw InputError(model_at + ": camera key '" + c.key + "' is missing: lens model '" + model +
                       "' needs " + expected);
    }
    *c.value = ToNumber(path, c.key, node);
  }
  return lens;
}

}  // namespace

CameraYaml ReadCameraYaml(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::Load(ReadWholeFile(path, "camera file", kMaxTextFileBytes));
  } catch (const YAML::Exception& e) {
    throw InputError(path + (e.mark.is_null() ? "" : ":" + std::to_string(e.mark.line + 1)) +
                     ": malformed YAML: " + e.msg);
  }
  if (!root.IsMap()) {
    throw InputError(path + ": expected a mapping of camera keys (fx, fy, cx, cy, width, height)");
  }
  static const std::vector<std::string> kKnown = {
      "model",      "width",      "height", "fx", "fy", "cx", "cy", "depth_scale", "fps",
      "timestamps", "distortion", "k1",     "k2", "k3", "k4", "p1", "p2"};
  std::set<std::string> seen;
  for (const auto& item : root) {
    const std::string key = item.first.Scalar();
    if (std::find(kKnown.begin(), kKnown.end(), key) == kKnown.end()) {
      const std::string best = ClosestMatch(key, kKnown);
      throw InputError(At(path, item.first) + ": unknown camera key '" + key + "'" +
                       (best.empty() ? std::string(" (known: fx fy cx cy width height "
                                                   "depth_scale fps timestamps model k1 k2 k3 "
                                                   "k4 p1 p2)")
                                     : " (did you mean '" + best + "'?)"));
    }
    if (!seen.insert(key).second) {
      throw InputError(At(path, item.first) + ": camera key '" + key + "' appears twice");
    }
  }
  for (const char* required : {"width", "height", "fx", "fy", "cx", "cy"}) {
    if (!root[required]) {
      throw InputError(path + ": camera key '" + required +
                       "' is missing (need fx, fy, cx, cy, width, height)");
    }
  }
  CameraYaml out;
  out.lens = ReadLens(path, root);
  if (root["distortion"]) {
    const YAML::Node d = root["distortion"];
    if (!d.IsSequence()) {
      throw InputError(At(path, d) + ": camera key 'distortion': expected a list of numbers");
    }
    for (const auto& c : d) {
      if (ToNumber(path, "distortion", c) != 0.0) {
        throw InputError(At(path, c) +
                         ": camera key 'distortion' must be all zero: give lens distortion as "
                         "'model: radtan' with keys k1 k2 p1 p2 (k3) or 'model: equidistant' "
                         "with keys k1 k2 k3 k4");
      }
    }
  }
  out.camera.width = ToInt(path, "width", root["width"]);
  out.camera.height = ToInt(path, "height", root["height"]);
  out.camera.fx = ToNumber(path, "fx", root["fx"]);
  out.camera.fy = ToNumber(path, "fy", root["fy"]);
  out.camera.cx = ToNumber(path, "cx", root["cx"]);
  out.camera.cy = ToNumber(path, "cy", root["cy"]);
  CheckCalibration(out.camera, path);
  if (root["depth_scale"]) {
    const double s = ToNumber(path, "depth_scale", root["depth_scale"]);
    if (!(s > 0)) {
      throw InputError(At(path, root["depth_scale"]) + ": camera key 'depth_scale' = " +
                       root["depth_scale"].Scalar() + " violates > 0");
    }
    out.depth_scale = s;
  }
  if (root["fps"]) {
    const double fps = ToNumber(path, "fps", root["fps"]);
    if (!(fps > 0)) {
      throw InputError(At(path, root["fps"]) + ": camera key 'fps' = " + root["fps"].Scalar() +
                       " violates > 0");
    }
    out.fps = fps;
  }
  if (root["timestamps"]) {
    const YAML::Node t = root["timestamps"];
    if (!t.IsScalar() || t.Scalar().empty()) {
      throw InputError(At(path, t) + ": camera key 'timestamps': expected a file name");
    }
    fs::path p(t.Scalar());
    if (p.is_relative()) p = fs::path(path).parent_path() / p;
    out.timestamps_path = p.string();
  }
  return out;
}

void WriteCameraYaml(const std::string& path, const CameraYaml& camera) {
  const auto parent = fs::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) fs::create_directories(parent, ec);
  std::ofstream file(path);
  if (!file) throw InputError("cannot write camera file " + path);
  char buf[512];
  const LensDistortion& lens = camera.lens;
  if (lens.model == LensModel::kPinhole) {
    file << "# pinhole camera of rectified images (dfo camera.yaml)\n";
  } else {
    file << "# camera with lens distortion (dfo camera.yaml; coefficients as OpenCV's)\n";
  }
  std::snprintf(buf, sizeof(buf),
                "model: %s\nwidth: %d\nheight: %d\nfx: %.17g\nfy: %.17g\ncx: %.17g\ncy: %.17g\n",
                LensModelName(lens.model), camera.camera.width, camera.camera.height,
                camera.camera.fx, camera.camera.fy, camera.camera.cx, camera.camera.cy);
  file << buf;
  if (lens.model == LensModel::kRadtan) {
    std::snprintf(buf, sizeof(buf), "k1: %.17g\nk2: %.17g\np1: %.17g\np2: %.17g\nk3: %.17g\n",
                  lens.k1, lens.k2, lens.p1, lens.p2, lens.k3);
    file << buf;
  } else if (lens.model == LensModel::kEquidistant) {
    std::snprintf(buf, sizeof(buf), "k1: %.17g\nk2: %.17g\nk3: %.17g\nk4: %.17g\n", lens.k1,
                  lens.k2, lens.k3, lens.k4);
    file << buf;
  }
  if (camera.depth_scale) {
    std::snprintf(buf, sizeof(buf), "depth_scale: %.17g   # depth PNG value per metre\n",
                  *camera.depth_scale);
    file << buf;
  }
  if (camera.fps) {
    std::snprintf(buf, sizeof(buf), "fps: %.17g\n", *camera.fps);
    file << buf;
  }
  if (!camera.timestamps_path.empty()) file << "timestamps: \"" << camera.timestamps_path << "\"\n";
  if (!file) throw InputError("error while writing camera file " + path);
}

}  // namespace dfo::io
