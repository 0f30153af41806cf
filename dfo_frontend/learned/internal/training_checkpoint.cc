// The trainer's checkpoints (networks, Adam state, iteration, history, run scales) and its loss
// history as CSV.
#include <torch/torch.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_frontend/learned/internal/training.h"
#include "dfo_frontend/learned/internal/zip_archive.h"

namespace dfo::learned {

namespace {

// Text of the options that fix the networks' parameter shapes (checked on resume).
std::string ShapeSignature(const NetworkOptions& o) {
  std::ostringstream s;
  auto list = [&s](const char* name, const auto& v) {
    s << name << "=[";
    for (size_t i = 0; i < v.size(); ++i) s << (i ? "," : "") << v[i];
    s << "] ";
  };
  s << "num_levels=" << o.num_levels << " ";
  list("channels", o.channels);
  list("depth_encoder_widths", o.depth_encoder_widths);
  list("depth_decoder_widths", o.depth_decoder_widths);
  list("feature_encoder_widths", o.feature_encoder_widths);
  list("feature_decoder_widths", o.feature_decoder_widths);
  s << "reconstruction_width=" << o.reconstruction_width;
  return s.str();
}

// Columns of the history (checkpoint tensor and CSV). Older checkpoints and CSVs have fewer:
// the first 12 before the pose-error diagnostic (the two pose errors then read NaN), the first
// 14 before the geometry-consistency term, the first 15 before the depth-target term (each then
// reads 0).
constexpr int kHistoryColumns = 16;
constexpr int kConsistencyColumns = 15;
constexpr int kPoseErrorColumns = 14;
constexpr int kOldHistoryColumns = 12;

// A record as a history row (stage 0 = ae, 1 = joint), and back from the first `columns` values
// of a row (the rest keep their defaults: NaN pose errors, 0 consistency and teacher terms).
std::array<double, kHistoryColumns> HistoryRow(const StepRecord& r) {
  return {static_cast<double>(r.iteration),
          r.stage == "ae" ? 0.0 : 1.0,
          r.total,
          r.appearance,
          r.smoothness,
          r.sparsity,
          r.reconstruction,
          r.learning_rate,
          r.temperature,
          r.gn_ok_ratio,
          r.mean_depth,
          r.seconds,
          r.pose_rotation_error_deg,
          r.pose_direction_error_deg,
          r.consistency,
          r.teacher};
}

StepRecord RecordFromRow(const std::vector<double>& row) {
  StepRecord r;
  r.iteration = static_cast<int>(row[0]);
  r.stage = row[1] == 0.0 ? "ae" : "joint";
  r.total = row[2];
  r.appearance = row[3];
  r.smoothness = row[4];
  r.sparsity = row[5];
  r.reconstruction = row[6];
  r.learning_rate = row[7];
  r.temperature = row[8];
  r.gn_ok_ratio = row[9];
  r.mean_depth = row[10];
  r.seconds = row[11];
  const size_t n = row.size();
  if (n >= kPoseErrorColumns) {
    r.pose_rotation_error_deg = row[12];
    r.pose_direction_error_deg = row[13];
  }
  if (n >= kConsistencyColumns) r.consistency = row[14];
  if (n >= kHistoryColumns) r.teacher = row[15];
  return r;
}

}  // namespace

void Trainer::SaveCheckpoint(const std::string& path) const {
  torch::serialize::OutputArchive archive;
  torch::serialize::OutputArchive nets, optim;
  networks_->save(nets);
  optimizer_->save(optim);
  archive.write("networks", nets);
  archive.write("optimizer", optim);
  archive.write("iteration", torch::tensor(static_cast<int64_t>(iteration_)));
  archive.write("shape", c10::IValue(ShapeSignature(options_.network)));
  torch::Tensor h =
      torch::zeros({static_cast<int64_t>(history_.size()), kHistoryColumns}, torch::kFloat64);
  auto a = h.accessor<double, 2>();
  for (size_t i = 0; i < history_.size(); ++i) {
    const std::array<double, kHistoryColumns> row = HistoryRow(history_[i]);
    for (int c = 0; c < kHistoryColumns; ++c) a[i][c] = row[c];
  }
  archive.write("history", h);
  archive.write("teacher_log_scales",
                torch::tensor(teacher_log_scales_, torch::TensorOptions().dtype(torch::kFloat64)));
  const std::string tmp = path + ".tmp";
  try {
    archive.save_to(tmp);
  } catch (const c10::Error& e) {
    throw InputError("checkpoint " + tmp + ": cannot be written (" + e.what_without_backtrace() +
                     ")");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    throw InputError("checkpoint " + path + ": cannot rename " + tmp + " to it");
  }
}

namespace {

// Opens a checkpoint with every tensor mapped to `device` (checkpoints hold the tensors of the
// device they were trained on: one written on a GPU loads on a CPU-only machine).
torch::serialize::InputArchive OpenCheckpoint(const std::string& path,
                                              const torch::Device& device) {
  // A checkpoint changed after it was written (a disk error, a copy cut short) is refused before
  // training resumes from it.
  CheckZipArchive(path, "checkpoint " + path);
  torch::serialize::InputArchive archive;
  try {
    archive.load_from(path, device);
  } catch (const c10::Error& e) {
    throw InputError("checkpoint " + path + ": not a dfo_train checkpoint or unreadable (" +
                     std::string(e.what_without_backtrace()).substr(0, 200) + ")");
  }
  return archive;
}

void CheckShape(torch::serialize::InputArchive& archive, const std::string& path,
                const NetworkOptions& options) {
  c10::IValue shape;
  if (!archive.try_read("shape", shape) || !shape.isString()) {
    throw InputError("checkpoint " + path + ": no 'shape' record; not a dfo_train checkpoint");
  }
  const std::string expected = ShapeSignature(options);
  if (shape.toStringRef() != expected) {
    throw InputError("checkpoint " + path + ": networks are " + shape.toStringRef() +
                     " but the configuration asks for " + expected);
  }
}

}  // namespace

void Trainer::LoadCheckpoint(const std::string& path) {
  torch::serialize::InputArchive archive = OpenCheckpoint(path, device_);
  CheckShape(archive, path, options_.network);
  try {
    torch::serialize::InputArchive nets, optim;
    archive.read("networks", nets);
    archive.read("optimizer", optim);
    networks_->load(nets);
    if (options_.channels_last) ToChannelsLast(*networks_);
    optimizer_->load(optim);
    torch::Tensor it, h;
    archive.read("iteration", it);
    archive.read("history", h);
    iteration_ = static_cast<int>(it.item<int64_t>());
    history_.clear();
    h = h.to(torch::kCPU, torch::kFloat64).contiguous();
    auto a = h.accessor<double, 2>();
    for (int64_t i = 0; i < h.size(0); ++i) {
      std::vector<double> row(static_cast<size_t>(std::min<int64_t>(h.size(1), kHistoryColumns)));
      for (size_t c = 0; c < row.size(); ++c) row[c] = a[i][static_cast<int64_t>(c)];
      history_.push_back(RecordFromRow(row));
    }
    // Checkpoints from before depth targets have no run scales: they are fitted afresh.
    torch::Tensor scales;
    if (archive.try_read("teacher_log_scales", scales) &&
        scales.numel() == static_cast<int64_t>(teacher_log_scales_.size())) {
      scales = scales.to(torch::kCPU, torch::kFloat64).contiguous();
      for (int64_t i = 0; i < scales.numel(); ++i) {
        teacher_log_scales_[static_cast<size_t>(i)] = scales.data_ptr<double>()[i];
      }
    }
  } catch (const c10::Error& e) {
    throw InputError("checkpoint " + path + ": " +
                     std::string(e.what_without_backtrace()).substr(0, 300));
  }
}

void Trainer::LoadWeights(const std::string& path) {
  torch::serialize::InputArchive archive = OpenCheckpoint(path, device_);
  CheckShape(archive, path, options_.network);
  try {
    torch::serialize::InputArchive nets;
    archive.read("networks", nets);
    networks_->load(nets);
    if (options_.channels_last) ToChannelsLast(*networks_);
  } catch (const c10::Error& e) {
    throw InputError("checkpoint " + path + ": " +
                     std::string(e.what_without_backtrace()).substr(0, 300));
  }
}

void WriteHistoryCsv(const std::string& path, const std::vector<StepRecord>& history) {
  std::ofstream out(path);
  if (!out) throw InputError("loss history " + path + ": cannot be written");
  out << "iteration,stage,total,appearance,smoothness,sparsity,reconstruction,learning_rate,"
         "temperature,gn_ok_ratio,mean_depth_m,seconds,pose_rotation_error_deg,"
         "pose_direction_error_deg,consistency,teacher\n";
  out.precision(9);
  for (const StepRecord& r : history) {
    const std::array<double, kHistoryColumns> row = HistoryRow(r);
    out << r.iteration << "," << r.stage;
    for (int c = 2; c < kHistoryColumns; ++c) out << "," << row[c];
    out << "\n";
  }
  if (!out) throw InputError("loss history " + path + ": write failed");
}

std::vector<StepRecord> ReadHistoryCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError("loss history " + path + ": cannot be read");
  std::vector<StepRecord> out;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1 || line.empty()) continue;
    std::stringstream ss(line);
    std::string field;
    std::vector<std::string> f;
    while (std::getline(ss, field, ',')) f.push_back(field);
    if (f.size() != kHistoryColumns && f.size() != kConsistencyColumns &&
        f.size() != kPoseErrorColumns && f.size() != kOldHistoryColumns) {
      std::ostringstream msg;
      msg << "loss history " << path << ":" << line_no << ": " << f.size() << " fields, expected "
          << kHistoryColumns;
      throw InputError(msg.str());
    }
    try {
      std::vector<double> row(f.size());
      row[0] = std::stoi(f[0]);
      row[1] = f[1] == "ae" ? 0.0 : 1.0;
      for (size_t c = 2; c < f.size(); ++c) row[c] = std::stod(f[c]);
      StepRecord r = RecordFromRow(row);
      r.stage = f[1];
      out.push_back(r);
    } catch (const std::exception&) {
      std::ostringstream msg;
      msg << "loss history " << path << ":" << line_no << ": not a number in '" << line << "'";
      throw InputError(msg.str());
    }
  }
  return out;
}

}  // namespace dfo::learned
