#include "dfo_frontend/learned/network_options.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "dfo_core/check_option.h"
#include "dfo_core/error.h"

namespace dfo::learned {

using ::dfo::internal::CheckOption;

namespace {

template <typename T>
std::string ListString(const std::vector<T>& v) {
  std::ostringstream s;
  s << "[";
  for (size_t i = 0; i < v.size(); ++i) s << (i ? ", " : "") << v[i];
  s << "]";
  return s.str();
}

template <typename T>
void CheckListSize(const std::vector<T>& v, size_t expected, const std::string& field,
                   const std::string& expected_what) {
  if (v.size() == expected) return;
  std::ostringstream msg;
  msg << "network." << field << " = " << ListString(v) << " has " << v.size()
      << " entries; expected " << expected_what << " = " << expected;
  throw ConfigError(msg.str());
}

void CheckWidths(const std::vector<int>& v, const std::string& field, int lo, int hi) {
  for (size_t i = 0; i < v.size(); ++i) {
    CheckOption(v[i] >= lo && v[i] <= hi, "network." + field + "[" + std::to_string(i) + "]", v[i],
                "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
}

}  // namespace

void NetworkOptions::Check() const {
  CheckOption(num_levels >= 1 && num_levels <= 6, "network.num_levels", num_levels, "in [1, 6]");
  const int div = 1 << (num_levels - 1);
  CheckOption(input_width >= 8 && input_width % div == 0, "network.input_width", input_width,
              ">= 8 and divisible by 2^(num_levels - 1) = " + std::to_string(div));
  CheckOption(input_height >= 8 && input_height % div == 0, "network.input_height", input_height,
              ">= 8 and divisible by 2^(num_levels - 1) = " + std::to_string(div));
  const size_t levels = static_cast<size_t>(num_levels);
  CheckListSize(channels, levels, "channels", "num_levels");
  CheckWidths(channels, "channels", 1, 256);
  CheckListSize(patch_sizes, levels, "patch_sizes", "num_levels");
  for (size_t i = 0; i < patch_sizes.size(); ++i) {
    CheckOption(patch_sizes[i] >= 1 && patch_sizes[i] <= 9 && patch_sizes[i] % 2 == 1,
                "network.patch_sizes[" + std::to_string(i) + "]", patch_sizes[i],
                "odd and in [1, 9]");
  }
  CheckListSize(rho, levels, "rho", "num_levels");
  for (size_t i = 0; i < rho.size(); ++i) {
    CheckOption(std::isfinite(rho[i]) && rho[i] > 0.0 && rho[i] <= 1.0,
                "network.rho[" + std::to_string(i) + "]", rho[i], "in (0, 1]");
  }
  CheckListSize(input_mean, 3, "input_mean", "RGB channels");
  CheckListSize(input_std, 3, "input_std", "RGB channels");
  for (int c = 0; c < 3; ++c) {
    CheckOption(std::isfinite(input_mean[c]), "network.input_mean[" + std::to_string(c) + "]",
                input_mean[c], "finite");
    CheckOption(std::isfinite(input_std[c]) && input_std[c] > 0.0,
                "network.input_std[" + std::to_string(c) + "]", input_std[c], "> 0");
  }
  if (depth_encoder_widths.size() < levels) {
    std::ostringstream msg;
    msg << "network.depth_encoder_widths = " << ListString(depth_encoder_widths) << " has "
        << depth_encoder_widths.size() << " entries; expected at least num_levels = " << num_levels;
    throw ConfigError(msg.str());
  }
  CheckWidths(depth_encoder_widths, "depth_encoder_widths", 1, 1024);
  CheckListSize(depth_decoder_widths, depth_encoder_widths.size(), "depth_decoder_widths",
                "the size of depth_encoder_widths");
  CheckWidths(depth_decoder_widths, "depth_decoder_widths", 1, 1024);
  CheckListSize(feature_encoder_widths, levels, "feature_encoder_widths", "num_levels");
  CheckWidths(feature_encoder_widths, "feature_encoder_widths", 1, 1024);
  CheckListSize(feature_decoder_widths, levels, "feature_decoder_widths", "num_levels");
  CheckWidths(feature_decoder_widths, "feature_decoder_widths", 1, 1024);
  CheckOption(reconstruction_width >= 1 && reconstruction_width <= 1024,
              "network.reconstruction_width", reconstruction_width, "in [1, 1024]");
}

int64_t NetworkOptions::LevelPixels(int width, int height, int level) {
  return static_cast<int64_t>(width >> level) * static_cast<int64_t>(height >> level);
}

bool operator==(const NetworkOptions& a, const NetworkOptions& b) {
  return a.input_width == b.input_width && a.input_height == b.input_height &&
         a.num_levels == b.num_levels && a.channels == b.channels &&
         a.patch_sizes == b.patch_sizes && a.rho == b.rho && a.input_mean == b.input_mean &&
         a.input_std == b.input_std && a.depth_encoder_widths == b.depth_encoder_widths &&
         a.depth_decoder_widths == b.depth_decoder_widths &&
         a.feature_encoder_widths == b.feature_encoder_widths &&
         a.feature_decoder_widths == b.feature_decoder_widths &&
         a.reconstruction_width == b.reconstruction_width;
}

double EstimateTrainingMemoryMib(const NetworkOptions& network, int batch_size) {
  // Feature maps per input pixel: encoder stage i at 1 / 2^(i+1) of each side, decoder stage i
  // and output level i at 1 / 2^i, the reconstruction heads at full size.
  double maps = network.reconstruction_width;
  const auto add = [&maps](const std::vector<int>& widths, int first_halvings) {
    for (size_t i = 0; i < widths.size(); ++i) {
      maps += widths[i] / std::pow(4.0, static_cast<double>(i) + first_halvings);
    }
  };
  add(network.depth_encoder_widths, 1);
  add(network.depth_decoder_widths, 0);
  add(network.feature_encoder_widths, 1);
  add(network.feature_decoder_widths, 0);
  add(network.channels, 0);
  const double pixels =
      static_cast<double>(network.input_width) * static_cast<double>(network.input_height);
  constexpr double kFixedMib = 300.0, kBytesPerMap = 100.0, kMargin = 1.2;
  return kFixedMib +
         kMargin * kBytesPerMap * maps * pixels * std::max(1, batch_size) / (1024.0 * 1024.0);
}

}  // namespace dfo::learned
