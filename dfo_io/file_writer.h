// Writing a whole file so that its final name never holds a partial write: the bytes go to
// "<path>.tmp", which is renamed onto `path` once written and closed. Every output file of dfo
// (trajectories, summaries, CSV, images and plots) is written this way.
#ifndef DFO_IO_FILE_WRITER_H_
#define DFO_IO_FILE_WRITER_H_

#include <string>

namespace dfo::io {

// Writes `bytes` to `path`, creating missing parent folders. Throws InputError
// "<what> <path>: cannot be written (<the system's reason>)" when it fails; `path` then keeps
// what it held before and no temporary file is left.
void WriteFileAtomically(const std::string& path, const std::string& bytes,
                         const std::string& what);

// Checks, before any work, that WriteFileAtomically(path, ...) can succeed: `path` is not a
// folder and "<path>.tmp" can be created in its folder (created if missing; the probe is
// removed). Throws InputError "<what> <path>: cannot be written (<reason>)" otherwise.
void CheckFileWritable(const std::string& path, const std::string& what);

// Creates folder `path` and its parents when missing. Throws InputError "cannot create <what>
// <path>: <reason>" (a file of that name exists, or the system's reason) otherwise.
void CreateFolder(const std::string& path, const std::string& what);

}  // namespace dfo::io

#endif  // DFO_IO_FILE_WRITER_H_
