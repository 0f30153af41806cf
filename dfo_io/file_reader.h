// Reading a whole file into memory with a size cap checked before anything is allocated, so a
// huge or wrong file (a video given as a configuration, /dev/zero) is one clear error instead of
// an out-of-memory failure.
#ifndef DFO_IO_FILE_READER_H_
#define DFO_IO_FILE_READER_H_

#include <cstddef>
#include <string>

namespace dfo::io {

// The caps of the readers below; each names the largest plausible file of its kind with a wide
// margin.
inline constexpr std::size_t kMaxTextFileBytes = 1 << 20;           // YAML (configs: ~16 KB)
inline constexpr std::size_t kMaxImageFileBytes = 256u << 20;       // one image file

// Returns the bytes of `path` (a file, or a pipe or device read up to the cap). Throws
// InputError naming `what` and `path` when it is missing, a folder, larger than `max_bytes` (with
// its size), or unreadable (with the system's reason).
std::string ReadWholeFile(const std::string& path, const std::string& what,
                          std::size_t max_bytes);

}  // namespace dfo::io

#endif  // DFO_IO_FILE_READER_H_
