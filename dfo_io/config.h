// Schema-driven YAML configuration.
//
// A ConfigSchema declares every key dfo understands as "section.key" with its type, default value,
// valid range (or allowed values) and a one-line doc. LoadConfig reads a YAML file of the form
//
//   dataset:
//     type: kitti
//     image_width: 416
//   run:
//     threads: 2
//
// checks it against the schema, applies `--set section.key=value` overrides and returns a Config
// with typed getters. Every value remembers where it came from ("default", "file.yaml:12",
// "--set"). Errors from outside (unknown section or key, wrong type, out of range, malformed YAML,
// bad override) throw dfo::ConfigError naming the file, the 1-based line and the key path, with a
// "did you mean" suggestion for misspelt names. Asking the Config for an undeclared key or with the
// wrong type is a programming error: dfo::InternalError.
//
// Config::ToYaml() writes every key (defaults included) with its doc as a comment; the result loads
// back to the same values, so it is what dfo saves as config_effective.yaml next to its results.
#ifndef DFO_IO_CONFIG_H_
#define DFO_IO_CONFIG_H_

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace dfo::io {

// Type of a configuration value. The order matches the alternatives of ConfigValue.
enum class ConfigType { kBool, kInt, kDouble, kString, kIntList, kDoubleList, kStringList };

// "bool", "int", "double", "string", "list of int", ...
const char* ConfigTypeName(ConfigType type);

// A typed configuration value; the alternative index equals static_cast<int>(ConfigType).
using ConfigValue = std::variant<bool, int64_t, double, std::string, std::vector<int64_t>,
                                 std::vector<double>, std::vector<std::string>>;

// The declaration of one key: type, default, rule and documentation. Built through
// ConfigSchema::Add*(); the range setters chain:
//   schema.AddDouble("keyframe.translation_ratio", 0.1, "...").GreaterThan(0).Max(1);
// Numeric rules apply to ints, doubles and to every element of numeric lists; OneOf and Matches
// apply to strings and to every element of string lists.
struct ConfigKey {
  std::string path;     // "section.key"
  std::string section;  // part before the first '.'
  std::string name;     // part after the first '.'
  ConfigType type = ConfigType::kBool;
  ConfigValue default_value;
  std::string doc;  // one line, shown as a comment by ToYaml

  // One side of a numeric range.
  struct Bound {
    double value = 0.0;
    bool exclusive = false;  // true: strict (<, >), false: inclusive (<=, >=)
  };
  std::optional<Bound> lower;        // value >= lower (or > when exclusive)
  std::optional<Bound> upper;        // value <= upper (or < when exclusive)
  std::vector<std::string> allowed;  // non-empty: the string must be one of these
  // Set: the string must satisfy it (Matches); `matches_rule` says the rule in words.
  std::function<bool(const std::string&)> matches;
  std::string matches_rule;

  ConfigKey& Min(double v);          // value >= v
  ConfigKey& GreaterThan(double v);  // value > v
  ConfigKey& Max(double v);          // value <= v
  ConfigKey& LessThan(double v);     // value < v
  ConfigKey& OneOf(std::vector<std::string> values);
  // A string rule that a list cannot say, e.g. "one of cpu, cuda, cuda:N": `accepts` decides,
  // `rule` is its text in RuleText and messages.
  ConfigKey& Matches(std::function<bool(const std::string&)> accepts, std::string rule);

  // The rule in words, e.g. "> 0, <= 1" or "one of kitti|tum|folder"; "" when unrestricted.
  std::string RuleText() const;
  // "" when `value` (of this key's type) satisfies the rule, else the broken rule, e.g. "> 0".
  std::string Violation(const ConfigValue& value) const;
};

// The set of sections and keys a program accepts. Keys keep their declaration order, which is the
// order of ToYaml's output.
class ConfigSchema {
 public:
  // Declares a section (must come before its keys); `doc` is a one-line comment.
  void AddSection(const std::string& name, const std::string& doc);

  // Declare keys "section.key". The section must have been declared; a path may be declared once.
  // The returned reference stays valid for the schema's lifetime (used to chain range rules).
  ConfigKey& AddBool(const std::string& path, bool default_value, const std::string& doc);
  ConfigKey& AddInt(const std::string& path, int64_t default_value, const std::string& doc);
  ConfigKey& AddDouble(const std::string& path, double default_value, const std::string& doc);
  ConfigKey& AddString(const std::string& path, const std::string& default_value,
                       const std::string& doc);
  ConfigKey& AddIntList(const std::string& path, std::vector<int64_t> default_value,
                        const std::string& doc);
  ConfigKey& AddDoubleList(const std::string& path, std::vector<double> default_value,
                           const std::string& doc);
  ConfigKey& AddStringList(const std::string& path, std::vector<std::string> default_value,
                           const std::string& doc);

  // The key declared as `path`, or nullptr.
  const ConfigKey* Find(const std::string& path) const;
  bool HasSection(const std::string& name) const;
  // Section names in declaration order, and a section's doc ("" for an unknown section).
  const std::vector<std::string>& sections() const { return sections_; }
  std::string SectionDoc(const std::string& name) const;
  // All keys in declaration order.
  const std::deque<ConfigKey>& keys() const { return keys_; }
  // Every key's full path, in declaration order.
  std::vector<std::string> KeyPaths() const;

  // Throws dfo::InternalError when a default violates its own rule (a bug in the schema).
  void Check() const;

 private:
  ConfigKey& Add(const std::string& path, ConfigType type, ConfigValue default_value,
                 const std::string& doc);

  std::vector<std::string> sections_;
  std::map<std::string, std::string> section_docs_;
  std::deque<ConfigKey> keys_;  // deque: references returned by Add* stay valid
  std::map<std::string, size_t> index_;
};

// A complete set of values for a schema: every declared key has a value and a source.
class Config {
 public:
  // All keys at their defaults (source "default"). Checks the schema (ConfigSchema::Check).
  explicit Config(const ConfigSchema& schema);

  // Typed getters. An undeclared key or a getter of the wrong type throws dfo::InternalError.
  bool GetBool(const std::string& path) const;
  int GetInt(const std::string& path) const;  // InternalError when the value does not fit an int
  int64_t GetInt64(const std::string& path) const;
  double GetDouble(const std::string& path) const;
  const std::string& GetString(const std::string& path) const;
  std::vector<int> GetIntList(const std::string& path) const;
  std::vector<double> GetDoubleList(const std::string& path) const;
  std::vector<std::string> GetStringList(const std::string& path) const;
  // The raw value (InternalError for an undeclared key).
  const ConfigValue& Get(const std::string& path) const;

  // Where the value came from: "default", "<file>:<line>" or "--set".
  const std::string& Source(const std::string& path) const;
  // Whether the value still comes from the schema's default.
  bool IsDefault(const std::string& path) const { return Source(path) == "default"; }

  // Sets a value of the key's type after checking its rule; a violated rule throws
  // dfo::ConfigError "<where>: <path> = <value> violates <rule>", where = `source`.
  // An undeclared key or a value of the wrong type is an InternalError.
  void Set(const std::string& path, const ConfigValue& value, const std::string& source);

  // Applies one override "section.key=value" (the text of a --set flag). The value is parsed as
  // YAML of the key's type ("[1, 2]" for lists). ConfigError for a missing '=', an unknown key
  // (with suggestion), a wrong type or a violated rule; the message quotes the override.
  void ApplyOverride(const std::string& override_text);

  // YAML text of every key (defaults included), each preceded by its doc and rule as a comment;
  // values not from the default carry a trailing "# from <source>" comment. Loads back to the same
  // values (doubles are printed with enough digits to round-trip).
  std::string ToYaml() const;
  // Writes ToYaml() to `path` (parent folders created); InputError when it cannot be written.
  void WriteYaml(const std::string& path) const;

  const ConfigSchema& schema() const { return *schema_; }

 private:
  struct Entry {
    ConfigValue value;
    std::string source;
  };
  const Entry& EntryOf(const std::string& path, ConfigType expected) const;

  std::shared_ptr<const ConfigSchema> schema_;
  std::map<std::string, Entry> values_;
};

// Reads `yaml_path` (skipped when empty: defaults only), validates it against `schema`, then
// applies `overrides` ("section.key=value", later ones win). Throws dfo::ConfigError (see the file
// comment) or dfo::InputError when the file cannot be read.
Config LoadConfig(const std::string& yaml_path, const ConfigSchema& schema,
                  const std::vector<std::string>& overrides = {});

// Same from YAML text; `name` stands for the file name in messages and sources.
Config LoadConfigFromString(const std::string& yaml_text, const std::string& name,
                            const ConfigSchema& schema,
                            const std::vector<std::string>& overrides = {});

// Formats a value as YAML text (flow style for lists, double-quoted strings, round-trip doubles).
std::string FormatConfigValue(const ConfigValue& value);

// Edit distance between two strings: insertions, deletions, substitutions and swaps of two
// neighbouring characters each cost 1 (optimal string alignment distance).
size_t EditDistance(const std::string& a, const std::string& b);
// The candidate closest to `word` by edit distance when close enough to be a plausible typo
// (distance <= max(2, |word| / 3)), else "".
std::string ClosestMatch(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace dfo::io

#endif  // DFO_IO_CONFIG_H_
