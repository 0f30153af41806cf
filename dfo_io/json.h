// A small JSON document type with a writer and a reader, no external dependency. Used for
// machine-readable results (dfo_eval --json, run summaries) and for reading them back in tests.
//
// Numbers are written with the fewest digits that read back to the same double (full
// precision); NaN and infinities, which JSON cannot represent, are written as null. Object keys
// keep their insertion order so output is stable and diff-friendly.
#ifndef DFO_IO_JSON_H_
#define DFO_IO_JSON_H_

#include <cstdint>
#include <initializer_list>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace dfo::io {

// One JSON value: null, boolean, number, string, array or object.
class JsonValue {
 public:
  enum class Type { kNull, kBool, kNumber, kString, kArray, kObject };

  // null.
  JsonValue() = default;
  JsonValue(std::nullptr_t) {}  // NOLINT(runtime/explicit): JsonValue v = nullptr;
  JsonValue(bool value) : type_(Type::kBool), bool_(value) {}  // NOLINT
  // Numbers. A non-finite double is stored as is and written as null.
  JsonValue(double value) : type_(Type::kNumber), number_(value) {}                  // NOLINT
  JsonValue(int value) : JsonValue(static_cast<int64_t>(value)) {}                   // NOLINT
  JsonValue(int64_t value);                                                          // NOLINT
  JsonValue(uint64_t value);                                                         // NOLINT
  JsonValue(const char* value) : type_(Type::kString), string_(value) {}             // NOLINT
  JsonValue(std::string value) : type_(Type::kString), string_(std::move(value)) {}  // NOLINT

  // An empty array / object.
  static JsonValue Array();
  static JsonValue Object();

  Type type() const { return type_; }
  bool IsNull() const { return type_ == Type::kNull; }
  bool IsNumber() const { return type_ == Type::kNumber; }
  bool IsString() const { return type_ == Type::kString; }
  bool IsArray() const { return type_ == Type::kArray; }
  bool IsObject() const { return type_ == Type::kObject; }

  // Accessors; each throws dfo::InputError when the value has another type.
  bool AsBool() const;
  double AsNumber() const;
  // The number as an exact integer when it was written as one (digits without '.'/exponent)
  // or is a whole double; throws otherwise.
  int64_t AsInt() const;
  const std::string& AsString() const;

  // Arrays: append, size, element. Push on null turns it into an array.
  JsonValue& Push(JsonValue value);
  size_t size() const;  // elements of an array / members of an object, 0 otherwise
  const JsonValue& operator[](size_t index) const;  // throws InputError when out of range
  const JsonValue& operator[](int index) const {    // so that v[0] is not ambiguous
    return (*this)[static_cast<size_t>(index)];
  }

  // Objects: set (replacing an existing key in place, else appending), lookup. Set on null
  // turns it into an object.
  JsonValue& Set(const std::string& key, JsonValue value);
  bool Has(const std::string& key) const;
  // The member `key`; throws InputError naming the key when absent.
  const JsonValue& operator[](const std::string& key) const;
  const JsonValue& operator[](const char* key) const { return (*this)[std::string(key)]; }
  // Members in insertion order.
  const std::vector<std::pair<std::string, JsonValue>>& members() const { return members_; }

  // Serialises the value. indent < 0: one line, no spaces; indent >= 0: pretty-printed with
  // that many spaces per level.
  std::string Dump(int indent = -1) const;

 private:
  void DumpTo(std::string* out, int indent, int level) const;

  Type type_ = Type::kNull;
  bool bool_ = false;
  double number_ = 0.0;
  bool is_integer_ = false;  // number_ holds an integer exactly given as integer_
  int64_t integer_ = 0;
  std::string string_;
  std::vector<JsonValue> elements_;
  std::vector<std::pair<std::string, JsonValue>> members_;
};

// Parses a JSON text (RFC 8259; one value, surrounding whitespace allowed). Throws
// dfo::InputError with the 1-based line and column of the problem. `source` names the text in
// messages (a file path, "stdout of dfo_eval", ...).
JsonValue ParseJson(const std::string& text, const std::string& source = "JSON text");

// JSON string literal of `s` with quotes: escapes ", \, and control characters (\n, \t, \uXXXX).
std::string JsonQuote(const std::string& s);

// Shortest decimal form of a finite double that reads back (strtod) to the same value, at most 17
// significant digits ("0.1", "1e-07", "4541"). "null" for NaN and infinities.
std::string FormatDouble(double value);

}  // namespace dfo::io

#endif  // DFO_IO_JSON_H_
