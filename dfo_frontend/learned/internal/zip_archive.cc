#include "dfo_frontend/learned/internal/zip_archive.h"

#include <zlib.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "dfo_core/error.h"

namespace dfo::learned {

namespace {

constexpr uint32_t kLocalHeader = 0x04034b50;
constexpr uint32_t kCentralHeader = 0x02014b50;
constexpr uint32_t kEndOfCentralDirectory = 0x06054b50;
constexpr uint32_t kZip64EndOfCentralDirectory = 0x06064b50;
constexpr uint32_t kZip64Locator = 0x07064b50;
constexpr size_t kEndRecordSize = 22;
constexpr size_t kMaxCommentSize = 65535;
constexpr size_t kChunk = 1 << 16;

uint64_t Le(const unsigned char* p, int bytes) {
  uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

std::string Hex(uint32_t v) {
  char buffer[16];
  std::snprintf(buffer, sizeof(buffer), "0x%08x", v);
  return buffer;
}

class Reader {
 public:
  Reader(const std::string& path, const std::string& what) : what_(what) {
    in_.open(path, std::ios::binary);
    if (!in_) throw InputError(what_ + ": cannot be opened");
    in_.seekg(0, std::ios::end);
    size_ = static_cast<uint64_t>(in_.tellg());
  }
  uint64_t size() const { return size_; }

  // `n` bytes at `offset`; throws naming `part` when they lie beyond the file's end.
  std::vector<unsigned char> Read(uint64_t offset, uint64_t n, const std::string& part) {
    if (offset > size_ || n > size_ - offset) {
      throw InputError(what_ + ": damaged or truncated archive: " + part + " (bytes " +
                       std::to_string(offset) + "-" + std::to_string(offset + n) +
                       ") lies beyond the file's end (" + std::to_string(size_) + " bytes)");
    }
    std::vector<unsigned char> out(n);
    in_.seekg(static_cast<std::streamoff>(offset));
    if (n > 0 && !in_.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(n))) {
      throw InputError(what_ + ": read error at byte " + std::to_string(offset));
    }
    return out;
  }

 private:
  std::string what_;
  std::ifstream in_;
  uint64_t size_ = 0;
};

// One central-directory entry.
struct Entry {
  std::string name;
  int method = 0;
  uint32_t crc = 0;
  uint64_t compressed = 0, uncompressed = 0, local_offset = 0;
};

// CRC-32 and size of a stored or deflated entry's data, read in chunks from `offset`.
void CheckEntryData(Reader& reader, const Entry& e, uint64_t offset, const std::string& what,
                    const std::string& label) {
  uint32_t crc = 0;
  uint64_t produced = 0;
  if (e.method == 0) {
    if (e.compressed != e.uncompressed) {
      throw InputError(what + ": damaged archive: " + label + " is stored with " +
                       std::to_string(e.compressed) + " bytes but declares " +
                       std::to_string(e.uncompressed));
    }
    for (uint64_t done = 0; done < e.compressed;) {
      const uint64_t n = std::min<uint64_t>(kChunk, e.compressed - done);
      const std::vector<unsigned char> bytes = reader.Read(offset + done, n, label);
      crc = Crc32(crc, bytes.data(), bytes.size());
      done += n;
    }
    produced = e.compressed;
  } else {
    z_stream z{};
    if (inflateInit2(&z, -MAX_WBITS) != Z_OK) {
      throw InputError(what + ": zlib cannot start inflating " + label);
    }
    std::vector<unsigned char> out(kChunk);
    int status = Z_OK;
    for (uint64_t done = 0; status != Z_STREAM_END;) {
      if (done >= e.compressed) break;  // input used up before the stream's end
      const uint64_t n = std::min<uint64_t>(kChunk, e.compressed - done);
      std::vector<unsigned char> in = reader.Read(offset + done, n, label);
      done += n;
      z.next_in = in.data();
      z.avail_in = static_cast<uInt>(in.size());
      // Until this input is used up and the output buffer was not filled (no output pending).
      do {
        z.next_out = out.data();
        z.avail_out = static_cast<uInt>(out.size());
        status = inflate(&z, Z_NO_FLUSH);
        if (status == Z_BUF_ERROR) {  // no progress possible: more input needed
          status = Z_OK;
          break;
        }
        if (status != Z_OK && status != Z_STREAM_END) {
          inflateEnd(&z);
          throw InputError(what + ": damaged archive: " + label +
                           " cannot be inflated (zlib: " + (z.msg ? z.msg : "data error") + ")");
        }
        const size_t got = out.size() - z.avail_out;
        crc = Crc32(crc, out.data(), got);
        produced += got;
      } while ((z.avail_in > 0 || z.avail_out == 0) && status != Z_STREAM_END);
    }
    inflateEnd(&z);
    if (status != Z_STREAM_END) {
      throw InputError(what + ": damaged archive: " + label + "'s compressed data ends early");
    }
  }
  if (produced != e.uncompressed) {
    throw InputError(what + ": damaged archive: " + label + " holds " + std::to_string(produced) +
                     " bytes but declares " + std::to_string(e.uncompressed));
  }
  if (crc != e.crc) {
    throw InputError(what + ": damaged archive: " + label + " fails its CRC-32 check (stored " +
                     Hex(e.crc) + ", computed " + Hex(crc) +
                     "): the file was changed after it was written; use an intact copy");
  }
}

}  // namespace

uint32_t Crc32(uint32_t crc, const void* data, size_t size) {
  const auto* bytes = static_cast<const Bytef*>(data);
  while (size > 0) {
    const uInt n = static_cast<uInt>(std::min<size_t>(size, std::numeric_limits<uInt>::max()));
    crc = static_cast<uint32_t>(crc32(crc, bytes, n));
    bytes += n;
    size -= n;
  }
  return crc;
}

ZipArchiveCheck CheckZipArchive(const std::string& path, const std::string& what) {
  ZipArchiveCheck result;
  Reader reader(path, what);
  const uint64_t size = reader.size();
  const bool starts_like_zip =
      size >= 4 && Le(reader.Read(0, 4, "the first bytes").data(), 4) == kLocalHeader;

  // The end-of-central-directory record: the last 22 bytes plus up to 64 KiB of comment.
  const uint64_t tail_size = std::min<uint64_t>(size, kEndRecordSize + kMaxCommentSize);
  const std::vector<unsigned char> tail = reader.Read(size - tail_size, tail_size, "the tail");
  int64_t end_at = -1;
  for (int64_t i = static_cast<int64_t>(tail.size()) - static_cast<int64_t>(kEndRecordSize); i >= 0;
       --i) {
    if (Le(&tail[i], 4) == kEndOfCentralDirectory) {
      end_at = i;
      break;
    }
  }
  if (end_at < 0) {
    if (!starts_like_zip) return result;
    throw InputError(what +
                     ": truncated or damaged archive: it starts like a ZIP archive but has "
                     "no end-of-central-directory record (" +
                     std::to_string(size) + " bytes; was the copy cut short?)");
  }
  result.is_zip = true;
  const unsigned char* end = &tail[end_at];
  const uint64_t end_offset = size - tail_size + static_cast<uint64_t>(end_at);
  uint64_t count = Le(end + 10, 2);
  uint64_t directory_size = Le(end + 12, 4);
  uint64_t directory_offset = Le(end + 16, 4);
  if (count == 0xFFFF || directory_size == 0xFFFFFFFF || directory_offset == 0xFFFFFFFF) {
    // ZIP64: the locator right before the record points at the ZIP64 record.
    if (end_offset < 20) throw InputError(what + ": damaged archive: ZIP64 locator missing");
    const std::vector<unsigned char> locator = reader.Read(end_offset - 20, 20, "ZIP64 locator");
    if (Le(locator.data(), 4) != kZip64Locator) {
      throw InputError(what + ": damaged archive: ZIP64 locator missing before the end record");
    }
    const std::vector<unsigned char> record =
        reader.Read(Le(&locator[8], 8), 56, "the ZIP64 end-of-central-directory record");
    if (Le(record.data(), 4) != kZip64EndOfCentralDirectory) {
      throw InputError(what +
                       ": damaged archive: the ZIP64 end record is not where its locator "
                       "points");
    }
    count = Le(&record[32], 8);
    directory_size = Le(&record[40], 8);
    directory_offset = Le(&record[48], 8);
  }
  const std::vector<unsigned char> directory =
      reader.Read(directory_offset, directory_size, "the central directory");
  size_t at = 0;
  for (uint64_t index = 0; index < count; ++index) {
    const std::string ordinal =
        "entry " + std::to_string(index + 1) + " of " + std::to_string(count);
    if (at + 46 > directory.size() || Le(&directory[at], 4) != kCentralHeader) {
      throw InputError(what + ": damaged archive: the central directory's " + ordinal +
                       " is not a valid header (byte " + std::to_string(directory_offset + at) +
                       ")");
    }
    const unsigned char* h = &directory[at];
    Entry e;
    e.method = static_cast<int>(Le(h + 10, 2));
    e.crc = static_cast<uint32_t>(Le(h + 16, 4));
    e.compressed = Le(h + 20, 4);
    e.uncompressed = Le(h + 24, 4);
    const size_t name_size = Le(h + 28, 2), extra_size = Le(h + 30, 2), comment = Le(h + 32, 2);
    e.local_offset = Le(h + 42, 4);
    if (at + 46 + name_size + extra_size + comment > directory.size()) {
      throw InputError(what + ": damaged archive: the central directory's " + ordinal +
                       " runs past the directory's end");
    }
    e.name.assign(reinterpret_cast<const char*>(h + 46), name_size);
    // ZIP64 extra field: the 64-bit values of the fields that hold 0xFFFFFFFF, in this order.
    for (size_t x = 46 + name_size; x + 4 <= 46 + name_size + extra_size;) {
      const uint64_t id = Le(h + x, 2), n = Le(h + x + 2, 2);
      if (id == 0x0001) {
        size_t v = x + 4;
        const auto take = [&](uint64_t* field) {
          if (*field != 0xFFFFFFFF || v + 8 > x + 4 + n) return;
          *field = Le(h + v, 8);
          v += 8;
        };
        take(&e.uncompressed);
        take(&e.compressed);
        take(&e.local_offset);
      }
      x += 4 + n;
    }
    at += 46 + name_size + extra_size + comment;
    const std::string label = "entry '" + e.name + "' (" + ordinal + ")";
    if (e.method != 0 && e.method != 8) {
      throw InputError(what + ": " + label + " uses ZIP compression method " +
                       std::to_string(e.method) + "; only stored (0) and deflate (8) are read");
    }
    const std::vector<unsigned char> local = reader.Read(e.local_offset, 30, label + "'s header");
    if (Le(local.data(), 4) != kLocalHeader) {
      throw InputError(what + ": damaged archive: " + label + "'s local header is not at byte " +
                       std::to_string(e.local_offset) + " where the directory says");
    }
    const uint64_t data_offset = e.local_offset + 30 + Le(&local[26], 2) + Le(&local[28], 2);
    CheckEntryData(reader, e, data_offset, what, label);
    ++result.entries;
    result.checked_bytes += static_cast<int64_t>(e.uncompressed);
  }
  return result;
}

}  // namespace dfo::learned
