#include "dfo_io/file_reader.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "dfo_core/error.h"

namespace dfo::io {

std::string ReadWholeFile(const std::string& path, const std::string& what,
                          std::size_t max_bytes) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) throw InputError(what + " not found: " + path);
  if (fs::is_directory(status)) {
    throw InputError(what + " " + path + " is a folder; expected a file");
  }
  if (!fs::is_regular_file(status)) {
    // A pipe (`--config <(...)`) or a device: read up to the cap.
    std::ifstream stream(path, std::ios::binary);
    if (!stream) {
      throw InputError("cannot read " + what + " " + path + ": " + std::strerror(errno));
    }
    std::string bytes;
    char buffer[65536];
    while (stream.read(buffer, sizeof(buffer)) || stream.gcount() > 0) {
      bytes.append(buffer, static_cast<std::size_t>(stream.gcount()));
      if (bytes.size() > max_bytes) {
        throw InputError(what + " " + path + " holds more than " + std::to_string(max_bytes) +
                         " bytes, the most that is read (the wrong file?)");
      }
    }
    return bytes;
  }
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw InputError("cannot read " + what + " " + path + ": " + ec.message());
  if (size > max_bytes) {
    throw InputError(what + " " + path + " is " + std::to_string(size) +
                     " bytes; at most " + std::to_string(max_bytes) + " are read (the wrong file?)");
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) {
    throw InputError("cannot read " + what + " " + path + ": " + std::strerror(errno));
  }
  std::string bytes(static_cast<std::size_t>(size), '\0');
  file.read(bytes.data(), static_cast<std::streamsize>(size));
  if (file.gcount() != static_cast<std::streamsize>(size)) {
    // The file shrank while being read (or a read error): keep what was read, say so.
    throw InputError("cannot read " + what + " " + path + ": read " +
                     std::to_string(file.gcount()) + " of " + std::to_string(size) + " bytes");
  }
  return bytes;
}

}  // namespace dfo::io
