// Reading line-based text files of numbers (trajectories, times, keyframe depth) with errors that
// name the file and the 1-based line: "path:line: what was found, what was expected".
#ifndef DFO_IO_TEXT_LINES_H_
#define DFO_IO_TEXT_LINES_H_

#include <fstream>
#include <string>
#include <vector>

namespace dfo::io {

// "path:line: " prefix of every reading error.
std::string Where(const std::string& path, int line);

// Opens a text file; throws InputError "<what> file not found: <path>" when it is missing, or
// naming it when it is a folder or cannot be opened.
std::ifstream OpenForReading(const std::string& path, const char* what);

// Splits a line into whitespace-separated tokens. Returns false for blank and '#' lines.
bool Tokenize(const std::string& line, std::vector<std::string>* tokens);

// A finite double from a whole token, or an InputError naming file, line and column (1-based
// token number).
double ParseNumber(const std::string& token, const std::string& path, int line, int column);

// Calls fn(line_number, line, tokens) for each line of the text file `path` that is not blank or
// a '#' comment (OpenForReading's errors for a missing file).
template <typename Fn>
void ForEachDataLine(const std::string& path, const char* what, Fn fn) {
  std::ifstream in = OpenForReading(path, what);
  std::string line;
  std::vector<std::string> tokens;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (Tokenize(line, &tokens)) fn(n, line, tokens);
  }
}

}  // namespace dfo::io

#endif  // DFO_IO_TEXT_LINES_H_
