// Integrity of ZIP archives (the container of LibTorch's model and checkpoint files).
//
// LibTorch reads a ZIP archive without checking its entries' CRC-32: a model file whose bytes
// were changed after it was written (a damaged download, a disk error, weights overwritten in
// place) loads and runs. CheckZipArchive reads the central directory and recomputes every
// entry's CRC-32 (stored entries directly, deflated ones after inflating them with zlib), so such
// a file is refused before its contents are used.
#ifndef DFO_FRONTEND_LEARNED_INTERNAL_ZIP_ARCHIVE_H_
#define DFO_FRONTEND_LEARNED_INTERNAL_ZIP_ARCHIVE_H_

#include <cstdint>
#include <string>

namespace dfo::learned {

// What CheckZipArchive found.
struct ZipArchiveCheck {
  bool is_zip = false;        // false: the file is no ZIP archive at all (nothing was checked)
  int64_t entries = 0;        // entries checked
  int64_t checked_bytes = 0;  // uncompressed bytes whose CRC-32 was recomputed
};

// Checks every entry of the ZIP archive at `path`: the central directory (ZIP64 included), each
// entry's local header, its data lying inside the file, its compression method (stored or
// deflate), its uncompressed size and its CRC-32. A file that does not start like a ZIP archive
// and has no end-of-central-directory record returns is_zip = false (the caller says what it
// expected). Throws InputError "<what>: ..." (e.g. what = "model file m.dfo") naming the entry and
// the damage: a truncated archive, an entry outside the file, a CRC-32 or size mismatch.
ZipArchiveCheck CheckZipArchive(const std::string& path, const std::string& what);

// CRC-32 (ISO-HDLC, as ZIP uses) of `size` bytes, continuing from `crc` (0 to start).
uint32_t Crc32(uint32_t crc, const void* data, size_t size);

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_INTERNAL_ZIP_ARCHIVE_H_
