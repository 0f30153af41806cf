#include "dfo_io/file_writer.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "dfo_core/error.h"

namespace dfo::io {

void WriteFileAtomically(const std::string& path, const std::string& bytes,
                         const std::string& what) {
  const std::filesystem::path p(path);
  std::error_code ec;
  if (!p.parent_path().empty()) std::filesystem::create_directories(p.parent_path(), ec);
  const std::string tmp = path + ".tmp";
  const auto fail = [&](int error, const std::string& detail) {
    std::remove(tmp.c_str());
    throw InputError(what + " " + path + ": cannot be written (" + detail + std::strerror(error) +
                     ")");
  };
  std::FILE* file = std::fopen(tmp.c_str(), "wb");
  if (file == nullptr) fail(errno, "");
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
  const int write_error = errno;
  const bool closed = std::fclose(file) == 0;
  if (!written) fail(write_error, "");
  if (!closed) fail(errno, "");
  if (std::rename(tmp.c_str(), path.c_str()) != 0) fail(errno, "renaming " + tmp + " onto it: ");
}

void CheckFileWritable(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw InputError(what + " " + path + ": cannot be written (it is a folder)");
  }
  const std::filesystem::path p(path);
  if (!p.parent_path().empty()) std::filesystem::create_directories(p.parent_path(), ec);
  const std::string tmp = path + ".tmp";
  std::FILE* file = std::fopen(tmp.c_str(), "wb");
  if (file == nullptr) {
    throw InputError(what + " " + path + ": cannot be written (" + std::strerror(errno) + ")");
  }
  std::fclose(file);
  std::remove(tmp.c_str());
}

void CreateFolder(const std::string& path, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(path, ec);
  std::error_code check;
  if (fs::is_directory(path, check)) return;
  std::string reason = ec ? ec.message() : "unknown reason";
  if (fs::exists(path, check)) reason = "a file of that name exists";
  throw InputError("cannot create " + what + " " + path + ": " + reason);
}

}  // namespace dfo::io
