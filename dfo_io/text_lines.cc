#include "dfo_io/text_lines.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "dfo_core/error.h"

namespace dfo::io {

// "path:line: " prefix of every reading error.
std::string Where(const std::string& path, int line) {
  return path + ":" + std::to_string(line) + ": ";
}

std::ifstream OpenForReading(const std::string& path, const char* what) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw InputError(std::string(what) + " file not found: " + path);
  }
  if (std::filesystem::is_directory(path, ec)) {
    throw InputError(std::string(what) + " file " + path + " is a folder, expected a text file");
  }
  std::ifstream in(path);
  if (!in) throw InputError(std::string("cannot open ") + what + " file " + path);
  return in;
}

// Splits a line into whitespace-separated tokens. Returns false for blank and '#' lines.
bool Tokenize(const std::string& line, std::vector<std::string>* tokens) {
  tokens->clear();
  size_t i = line.find_first_not_of(" \t\r\n");
  if (i == std::string::npos || line[i] == '#') return false;
  std::istringstream ss(line);
  std::string token;
  while (ss >> token) tokens->push_back(token);
  return true;
}

// A finite double from a whole token, or an InputError naming file, line and token.
double ParseNumber(const std::string& token, const std::string& path, int line, int column) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (end == token.c_str() || *end != '\0') {
    throw InputError(Where(path, line) + "number " + std::to_string(column) + " is '" + token +
                     "', expected a number");
  }
  if (!std::isfinite(v)) {
    throw InputError(Where(path, line) + "number " + std::to_string(column) + " is '" + token +
                     "', expected a finite value");
  }
  return v;
}

}  // namespace dfo::io
