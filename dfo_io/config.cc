#include "dfo_io/config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "dfo_core/error.h"
#include "dfo_io/file_reader.h"

namespace dfo::io {
namespace {

std::string Trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Shortest "%.*g" text that reads back to exactly `v`, with a '.' or exponent so that it reads as a
// floating-point number in YAML.
std::string FormatDouble(double v, bool force_point = true) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  char buf[64];
  bool found = false;
  const double magnitude = std::abs(v);
  if (magnitude == 0.0 || (magnitude >= 1e-4 && magnitude < 1e15)) {
    // Plain decimals ("80", "0.02") when few enough digits read back exactly.
    for (int decimals = 0; decimals <= 17 && !found; ++decimals) {
      std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
      found = std::strtod(buf, nullptr) == v;
    }
  }
  for (int precision = 1; precision <= 17 && !found; ++precision) {
    std::snprintf(buf, sizeof(buf), "%.*g", precision, v);
    found = std::strtod(buf, nullptr) == v;
  }
  std::string s = buf;
  if (force_point && s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

// Splits a comment into lines of at most `width` characters (at spaces).
std::vector<std::string> WrapWords(const std::string& text, size_t width) {
  std::vector<std::string> lines;
  std::istringstream words(text);
  std::string word, line;
  while (words >> word) {
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      lines.push_back(line);
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  if (!line.empty() || lines.empty()) lines.push_back(line);
  return lines;
}

std::string QuoteString(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\x%02x", static_cast<unsigned char>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

// What a value's type expects, for "expected ..., found ..." messages.
const char* Expected(ConfigType type) {
  switch (type) {
    case ConfigType::kBool:
      return "a boolean (true or false)";
    case ConfigType::kInt:
      return "an integer";
    case ConfigType::kDouble:
      return "a number";
    case ConfigType::kString:
      return "a string";
    case ConfigType::kIntList:
      return "a list of integers like [1, 2]";
    case ConfigType::kDoubleList:
      return "a list of numbers like [0.5, 1.0]";
    case ConfigType::kStringList:
      return "a list of strings like [a, b]";
  }
  return "?";
}

bool ParseBool(const std::string& text, bool* out) {
  const std::string t = Lower(text);
  if (t == "true" || t == "yes" || t == "on") {
    *out = true;
    return true;
  }
  if (t == "false" || t == "no" || t == "off") {
    *out = false;
    return true;
  }
  return false;
}

bool ParseInt(const std::string& text, int64_t* out) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (errno != 0 || end != text.c_str() + text.size()) return false;
  *out = static_cast<int64_t>(v);
  return true;
}

bool ParseDouble(const std::string& text, double* out) {
  if (text.empty()) return false;
  // YAML spellings of infinity are accepted; range rules reject them where they make no sense.
  const std::string t = Lower(text);
  if (t == ".inf" || t == "+.inf") {
    *out = std::numeric_limits<double>::infinity();
    return true;
  }
  if (t == "-.inf") {
    *out = -std::numeric_limits<double>::infinity();
    return true;
  }
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (errno == ERANGE || end != text.c_str() + text.size() || std::isnan(v)) return false;
  *out = v;
  return true;
}

// Parses one scalar of the element type of `type` (list types use their element type). Returns
// false with nothing written when the text does not fit.
bool ParseElement(ConfigType type, const std::string& text, ConfigValue* out) {
  switch (type) {
    case ConfigType::kBool: {
      bool b;
      if (!ParseBool(text, &b)) return false;
      *out = b;
      return true;
    }
    case ConfigType::kInt:
    case ConfigType::kIntList: {
      int64_t i;
      if (!ParseInt(text, &i)) return false;
      *out = i;
      return true;
    }
    case ConfigType::kDouble:
    case ConfigType::kDoubleList: {
      double d;
      if (!ParseDouble(text, &d)) return false;
      *out = d;
      return true;
    }
    case ConfigType::kString:
    case ConfigType::kStringList:
      *out = text;
      return true;
  }
  return false;
}

// Every list key holds a few values (one per pyramid level or network stage).
constexpr size_t kMaxConfigListElements = 64;

bool IsList(ConfigType type) {
  return type == ConfigType::kIntList || type == ConfigType::kDoubleList ||
         type == ConfigType::kStringList;
}

std::string Describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "nothing (null)";
    case YAML::NodeType::Scalar:
      return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a mapping";
    default:
      return "an undefined value";
  }
}

// " (beyond the 64-bit integer range)" / " (beyond the double range)" when `text` is a number
// that does not fit `type`, else "": says why a number that looks like one was refused.
std::string OutOfRangeNote(ConfigType type, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  if (type == ConfigType::kInt || type == ConfigType::kIntList) {
    std::strtoll(text.c_str(), &end, 10);
    if (errno == ERANGE && end == text.c_str() + text.size()) {
      return " (beyond the 64-bit integer range)";
    }
  } else if (type == ConfigType::kDouble || type == ConfigType::kDoubleList) {
    std::strtod(text.c_str(), &end);
    if (errno == ERANGE && end == text.c_str() + text.size()) return " (beyond the double range)";
  }
  return "";
}

// Converts a YAML node to a value of `type`; on failure returns false and sets *why to
// "expected ..., found ...".
bool NodeToValue(const YAML::Node& node, ConfigType type, ConfigValue* out, std::string* why) {
  const auto fail = [&](const std::string& found) {
    *why = std::string("expected ") + Expected(type) + ", found " + found;
    return false;
  };
  if (!IsList(type)) {
    if (type == ConfigType::kString && node.IsNull()) {
      *out = std::string();  // "key:" with nothing = empty string
      return true;
    }
    if (!node.IsScalar()) return fail(Describe(node));
    if (!ParseElement(type, node.Scalar(), out)) {
      return fail(Describe(node) + OutOfRangeNote(type, node.Scalar()));
    }
    return true;
  }
  if (node.IsNull()) return fail(Describe(node));
  if (!node.IsSequence()) return fail(Describe(node));
  if (node.size() > kMaxConfigListElements) {
    *why = "a list of " + std::to_string(node.size()) + " elements; at most " +
           std::to_string(kMaxConfigListElements) + " are allowed";
    return false;
  }
  std::vector<int64_t> ints;
  std::vector<double> doubles;
  std::vector<std::string> strings;
  size_t index = 0;
  for (const YAML::Node& element : node) {
    ConfigValue v;
    if (!element.IsScalar() || !ParseElement(type, element.Scalar(), &v)) {
      return fail(Describe(element) + " as element " + std::to_string(index));
    }
    if (type == ConfigType::kIntList) ints.push_back(std::get<int64_t>(v));
    if (type == ConfigType::kDoubleList) doubles.push_back(std::get<double>(v));
    if (type == ConfigType::kStringList) strings.push_back(std::get<std::string>(v));
    ++index;
  }
  if (type == ConfigType::kIntList) *out = ints;
  if (type == ConfigType::kDoubleList) *out = doubles;
  if (type == ConfigType::kStringList) *out = strings;
  return true;
}

int Line(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? 0 : mark.line + 1;
}

std::string Where(const std::string& file, int line) {
  return line > 0 ? file + ":" + std::to_string(line) : file;
}

std::string Suggestion(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string best = ClosestMatch(word, candidates);
  return best.empty() ? std::string() : " (did you mean '" + best + "'?)";
}

}  // namespace

const char* ConfigTypeName(ConfigType type) {
  switch (type) {
    case ConfigType::kBool:
      return "bool";
    case ConfigType::kInt:
      return "int";
    case ConfigType::kDouble:
      return "double";
    case ConfigType::kString:
      return "string";
    case ConfigType::kIntList:
      return "list of int";
    case ConfigType::kDoubleList:
      return "list of double";
    case ConfigType::kStringList:
      return "list of string";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------------
// ConfigKey

ConfigKey& ConfigKey::Min(double v) {
  lower = Bound{v, false};
  return *this;
}
ConfigKey& ConfigKey::GreaterThan(double v) {
  lower = Bound{v, true};
  return *this;
}
ConfigKey& ConfigKey::Max(double v) {
  upper = Bound{v, false};
  return *this;
}
ConfigKey& ConfigKey::LessThan(double v) {
  upper = Bound{v, true};
  return *this;
}
ConfigKey& ConfigKey::OneOf(std::vector<std::string> values) {
  allowed = std::move(values);
  return *this;
}
ConfigKey& ConfigKey::Matches(std::function<bool(const std::string&)> accepts, std::string rule) {
  matches = std::move(accepts);
  matches_rule = std::move(rule);
  return *this;
}

std::string ConfigKey::RuleText() const {
  const bool integral = type == ConfigType::kInt || type == ConfigType::kIntList;
  // Bounds print as plain numbers: "> 0", ">= 0.5".
  const auto bound = [&](const Bound& b) {
    if (integral && b.value == std::floor(b.value) && std::abs(b.value) < 1e15) {
      return std::to_string(static_cast<int64_t>(b.value));
    }
    return FormatDouble(b.value, /*force_point=*/false);
  };
  std::vector<std::string> parts;
  if (lower) parts.push_back((lower->exclusive ? "> " : ">= ") + bound(*lower));
  if (upper) parts.push_back((upper->exclusive ? "< " : "<= ") + bound(*upper));
  if (!allowed.empty()) {
    std::string s = "one of ";
    for (size_t i = 0; i < allowed.size(); ++i) s += (i ? "|" : "") + allowed[i];
    parts.push_back(s);
  }
  if (matches) parts.push_back(matches_rule);
  std::string out;
  for (size_t i = 0; i < parts.size(); ++i) out += (i ? ", " : "") + parts[i];
  return out;
}

std::string ConfigKey::Violation(const ConfigValue& value) const {
  const auto check_number = [&](double v) -> bool {
    if (lower && (lower->exclusive ? !(v > lower->value) : !(v >= lower->value))) return false;
    if (upper && (upper->exclusive ? !(v < upper->value) : !(v <= upper->value))) return false;
    return true;
  };
  const auto check_string = [&](const std::string& s) {
    return (allowed.empty() || std::find(allowed.begin(), allowed.end(), s) != allowed.end()) &&
           (!matches || matches(s));
  };
  bool ok = true;
  if (const auto* i = std::get_if<int64_t>(&value)) ok = check_number(static_cast<double>(*i));
  if (const auto* d = std::get_if<double>(&value)) ok = check_number(*d);
  if (const auto* s = std::get_if<std::string>(&value)) ok = check_string(*s);
  if (const auto* l = std::get_if<std::vector<int64_t>>(&value)) {
    for (const int64_t v : *l) ok = ok && check_number(static_cast<double>(v));
  }
  if (const auto* l = std::get_if<std::vector<double>>(&value)) {
    for (const double v : *l) ok = ok && check_number(v);
  }
  if (const auto* l = std::get_if<std::vector<std::string>>(&value)) {
    for (const auto& v : *l) ok = ok && check_string(v);
  }
  return ok ? std::string() : RuleText();
}

// ---------------------------------------------------------------------------------------------
// ConfigSchema

void ConfigSchema::AddSection(const std::string& name, const std::string& doc) {
  DFO_CHECK(!name.empty() && name.find('.') == std::string::npos) << "bad section name " << name;
  DFO_CHECK(!HasSection(name)) << "section declared twice: " << name;
  sections_.push_back(name);
  section_docs_[name] = doc;
}

ConfigKey& ConfigSchema::Add(const std::string& path, ConfigType type, ConfigValue default_value,
                             const std::string& doc) {
  const size_t dot = path.find('.');
  DFO_CHECK(dot != std::string::npos && dot > 0 && dot + 1 < path.size())
      << "config key '" << path << "' is not of the form section.key";
  DFO_CHECK(index_.count(path) == 0) << "config key declared twice: " << path;
  const std::string section = path.substr(0, dot);
  DFO_CHECK(HasSection(section)) << "section of " << path << " not declared";
  DFO_CHECK(default_value.index() == static_cast<size_t>(type)) << path;
  ConfigKey key;
  key.path = path;
  key.section = section;
  key.name = path.substr(dot + 1);
  key.type = type;
  key.default_value = std::move(default_value);
  key.doc = doc;
  index_[path] = keys_.size();
  keys_.push_back(std::move(key));
  return keys_.back();
}

ConfigKey& ConfigSchema::AddBool(const std::string& path, bool v, const std::string& doc) {
  return Add(path, ConfigType::kBool, v, doc);
}
ConfigKey& ConfigSchema::AddInt(const std::string& path, int64_t v, const std::string& doc) {
  return Add(path, ConfigType::kInt, v, doc);
}
ConfigKey& ConfigSchema::AddDouble(const std::string& path, double v, const std::string& doc) {
  return Add(path, ConfigType::kDouble, v, doc);
}
ConfigKey& ConfigSchema::AddString(const std::string& path, const std::string& v,
                                   const std::string& doc) {
  return Add(path, ConfigType::kString, v, doc);
}
ConfigKey& ConfigSchema::AddIntList(const std::string& path, std::vector<int64_t> v,
                                    const std::string& doc) {
  return Add(path, ConfigType::kIntList, std::move(v), doc);
}
ConfigKey& ConfigSchema::AddDoubleList(const std::string& path, std::vector<double> v,
                                       const std::string& doc) {
  return Add(path, ConfigType::kDoubleList, std::move(v), doc);
}
ConfigKey& ConfigSchema::AddStringList(const std::string& path, std::vector<std::string> v,
                                       const std::string& doc) {
  return Add(path, ConfigType::kStringList, std::move(v), doc);
}

const ConfigKey* ConfigSchema::Find(const std::string& path) const {
  const auto it = index_.find(path);
  return it == index_.end() ? nullptr : &keys_[it->second];
}

bool ConfigSchema::HasSection(const std::string& name) const {
  return section_docs_.count(name) > 0;
}

std::string ConfigSchema::SectionDoc(const std::string& name) const {
  const auto it = section_docs_.find(name);
  return it == section_docs_.end() ? std::string() : it->second;
}

std::vector<std::string> ConfigSchema::KeyPaths() const {
  std::vector<std::string> paths;
  paths.reserve(keys_.size());
  for (const auto& k : keys_) paths.push_back(k.path);
  return paths;
}

void ConfigSchema::Check() const {
  for (const auto& k : keys_) {
    const std::string broken = k.Violation(k.default_value);
    DFO_CHECK(broken.empty()) << "default of " << k.path << " = "
                              << FormatConfigValue(k.default_value) << " violates " << broken;
  }
}

// ---------------------------------------------------------------------------------------------
// Config

Config::Config(const ConfigSchema& schema) : schema_(std::make_shared<ConfigSchema>(schema)) {
  schema_->Check();
  for (const auto& k : schema_->keys()) values_[k.path] = Entry{k.default_value, "default"};
}

const Config::Entry& Config::EntryOf(const std::string& path, ConfigType expected) const {
  const ConfigKey* key = schema_->Find(path);
  DFO_CHECK(key != nullptr) << "configuration key '" << path << "' is not declared in the schema"
                            << Suggestion(path, schema_->KeyPaths());
  DFO_CHECK(key->type == expected)
      << "configuration key '" << path << "' is of type " << ConfigTypeName(key->type)
      << ", asked for type " << ConfigTypeName(expected);
  return values_.at(path);
}

bool Config::GetBool(const std::string& path) const {
  return std::get<bool>(EntryOf(path, ConfigType::kBool).value);
}
int64_t Config::GetInt64(const std::string& path) const {
  return std::get<int64_t>(EntryOf(path, ConfigType::kInt).value);
}
namespace {

// A value of an int key beyond the 32-bit range: a ConfigError naming where it came from.
void CheckFitsInt(const Config& config, const std::string& path, int64_t v) {
  if (v >= std::numeric_limits<int>::min() && v <= std::numeric_limits<int>::max()) return;
  throw ConfigError(config.Source(path) + ": " + path + " = " + std::to_string(v) +
                    " violates the integer range [" +
                    std::to_string(std::numeric_limits<int>::min()) + ", " +
                    std::to_string(std::numeric_limits<int>::max()) + "]");
}

}  // namespace

int Config::GetInt(const std::string& path) const {
  const int64_t v = GetInt64(path);
  CheckFitsInt(*this, path, v);
  return static_cast<int>(v);
}
double Config::GetDouble(const std::string& path) const {
  return std::get<double>(EntryOf(path, ConfigType::kDouble).value);
}
const std::string& Config::GetString(const std::string& path) const {
  return std::get<std::string>(EntryOf(path, ConfigType::kString).value);
}
std::vector<int> Config::GetIntList(const std::string& path) const {
  const auto& l = std::get<std::vector<int64_t>>(EntryOf(path, ConfigType::kIntList).value);
  std::vector<int> out;
  for (const int64_t v : l) {
    CheckFitsInt(*this, path, v);
    out.push_back(static_cast<int>(v));
  }
  return out;
}
std::vector<double> Config::GetDoubleList(const std::string& path) const {
  return std::get<std::vector<double>>(EntryOf(path, ConfigType::kDoubleList).value);
}
std::vector<std::string> Config::GetStringList(const std::string& path) const {
  return std::get<std::vector<std::string>>(EntryOf(path, ConfigType::kStringList).value);
}

const ConfigValue& Config::Get(const std::string& path) const {
  const ConfigKey* key = schema_->Find(path);
  DFO_CHECK(key != nullptr) << "configuration key '" << path << "' is not declared";
  return values_.at(path).value;
}

const std::string& Config::Source(const std::string& path) const {
  const ConfigKey* key = schema_->Find(path);
  DFO_CHECK(key != nullptr) << "configuration key '" << path << "' is not declared";
  return values_.at(path).source;
}

void Config::Set(const std::string& path, const ConfigValue& value, const std::string& source) {
  const ConfigKey* key = schema_->Find(path);
  DFO_CHECK(key != nullptr) << "configuration key '" << path << "' is not declared";
  DFO_CHECK(value.index() == static_cast<size_t>(key->type))
      << path << " is of type " << ConfigTypeName(key->type);
  const std::string broken = key->Violation(value);
  if (!broken.empty()) {
    throw ConfigError(source + ": " + path + " = " + FormatConfigValue(value) + " violates " +
                      broken);
  }
  values_[path] = Entry{value, source};
}

void Config::ApplyOverride(const std::string& override_text) {
  // A pasted megabyte stays out of the message.
  const std::string where =
      "--set '" +
      (override_text.size() <= 200 ? override_text
                                   : override_text.substr(0, 160) + "... (" +
                                         std::to_string(override_text.size()) + " characters)") +
      "'";
  const size_t eq = override_text.find('=');
  if (eq == std::string::npos) {
    throw ConfigError(where + ": no '=' found, expected section.key=value");
  }
  const std::string path = Trim(override_text.substr(0, eq));
  const std::string text = Trim(override_text.substr(eq + 1));
  const ConfigKey* key = schema_->Find(path);
  if (key == nullptr) {
    throw ConfigError(where + ": unknown configuration key '" + path + "'" +
                      Suggestion(path, schema_->KeyPaths()));
  }
  ConfigValue value;
  std::string why;
  bool ok = false;
  if (key->type == ConfigType::kString &&
      (text.empty() || (text.front() != '"' && text.front() != '\''))) {
    // Unquoted strings are taken verbatim (paths with ':' or '#' need no YAML quoting).
    value = text;
    ok = true;
  } else {
    YAML::Node node;
    try {
      node = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      throw ConfigError(where + ": " + path + ": malformed YAML value: " + e.msg);
    }
    ok = NodeToValue(node, key->type, &value, &why);
  }
  if (!ok) throw ConfigError(where + ": " + path + ": " + why);
  const std::string broken = key->Violation(value);
  if (!broken.empty()) {
    throw ConfigError(where + ": " + path + " = " + FormatConfigValue(value) + " violates " +
                      broken);
  }
  Set(path, value, "--set");
}

std::string Config::ToYaml() const {
  std::ostringstream out;
  out << "# dfo configuration: every key with its value. Each comment gives the key's meaning and\n"
         "# its valid range. Load with --config FILE; change single keys with --set "
         "section.key=value.\n";
  for (const std::string& section : schema_->sections()) {
    out << "\n";
    const std::string doc = schema_->SectionDoc(section);
    if (!doc.empty()) out << "# " << doc << "\n";
    out << section << ":";
    bool any = false;
    for (const ConfigKey& key : schema_->keys()) {
      if (key.section != section) continue;
      if (!any) out << "\n";
      any = true;
      const Entry& entry = values_.at(key.path);
      std::string comment = key.doc;
      const std::string rule = key.RuleText();
      if (!rule.empty()) comment += " [" + rule + "]";
      for (const std::string& line : WrapWords(comment, 94)) out << "  # " << line << "\n";
      out << "  " << key.name << ": " << FormatConfigValue(entry.value);
      if (entry.source != "default") out << "  # from " << entry.source;
      out << "\n";
    }
    if (!any) out << " {}\n";
  }
  return out.str();
}

void Config::WriteYaml(const std::string& path) const {
  const auto parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  errno = 0;
  std::ofstream file(path);
  if (!file) {
    throw InputError("cannot write configuration file " + path + ": " +
                     (errno != 0 ? std::strerror(errno) : "cannot be opened for writing"));
  }
  file << ToYaml();
  file.flush();
  if (!file) {
    throw InputError("error while writing configuration file " + path + ": " +
                     (errno != 0 ? std::strerror(errno) : "write failed"));
  }
}

// ---------------------------------------------------------------------------------------------
// Loading

Config LoadConfigFromString(const std::string& yaml_text, const std::string& name,
                            const ConfigSchema& schema, const std::vector<std::string>& overrides) {
  Config config(schema);
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    // yaml-cpp marks are 0-based; messages are 1-based like editors.
    const std::string where = e.mark.is_null() ? name
                                               : name + ":" + std::to_string(e.mark.line + 1) +
                                                     ":" + std::to_string(e.mark.column + 1);
    throw ConfigError(where + ": malformed YAML: " + e.msg);
  }
  if (root.IsDefined() && !root.IsNull()) {
    if (!root.IsMap()) {
      throw ConfigError(Where(name, Line(root)) +
                        ": the top level must be a mapping of sections (like 'dataset:'), found " +
                        Describe(root));
    }
    std::set<std::string> seen_sections;
    for (const auto& section_item : root) {
      const YAML::Node& section_node = section_item.first;
      const std::string section = section_node.Scalar();
      const int section_line = Line(section_node);
      if (!schema.HasSection(section)) {
        throw ConfigError(Where(name, section_line) + ": unknown section '" + section + "'" +
                          Suggestion(section, schema.sections()));
      }
      if (!seen_sections.insert(section).second) {
        throw ConfigError(Where(name, section_line) + ": section '" + section + "' appears twice");
      }
      const YAML::Node& keys = section_item.second;
      if (keys.IsNull()) continue;  // "section:" with nothing under it
      if (!keys.IsMap()) {
        throw ConfigError(Where(name, Line(keys)) + ": section '" + section +
                          "' must be a mapping of keys, found " + Describe(keys));
      }
      std::set<std::string> seen_keys;
      for (const auto& key_item : keys) {
        const std::string path = section + "." + key_item.first.Scalar();
        const int line = Line(key_item.first);
        const ConfigKey* key = schema.Find(path);
        if (key == nullptr) {
          throw ConfigError(Where(name, line) + ": unknown key '" + path + "'" +
                            Suggestion(path, schema.KeyPaths()));
        }
        if (!seen_keys.insert(path).second) {
          throw ConfigError(Where(name, line) + ": key '" + path + "' appears twice");
        }
        ConfigValue value;
        std::string why;
        if (!NodeToValue(key_item.second, key->type, &value, &why)) {
          throw ConfigError(Where(name, line) + ": " + path + ": " + why);
        }
        config.Set(path, value, Where(name, line));
      }
    }
  }
  for (const std::string& o : overrides) config.ApplyOverride(o);
  return config;
}

Config LoadConfig(const std::string& yaml_path, const ConfigSchema& schema,
                  const std::vector<std::string>& overrides) {
  if (yaml_path.empty()) return LoadConfigFromString("", "(defaults)", schema, overrides);
  std::error_code ec;
  if (std::filesystem::is_directory(yaml_path, ec)) {
    throw InputError("configuration file " + yaml_path + " is a folder; expected a YAML file");
  }
  return LoadConfigFromString(ReadWholeFile(yaml_path, "configuration file", kMaxTextFileBytes),
                              yaml_path, schema, overrides);
}

namespace {
// Formats each alternative of ConfigValue as YAML text.
struct ValueFormatter {
  std::string operator()(bool b) const { return b ? "true" : "false"; }
  std::string operator()(int64_t i) const { return std::to_string(i); }
  std::string operator()(double d) const { return FormatDouble(d); }
  std::string operator()(const std::string& s) const { return QuoteString(s); }
  template <typename T>
  std::string operator()(const std::vector<T>& l) const {
    std::string out = "[";
    for (size_t i = 0; i < l.size(); ++i) out += (i ? ", " : "") + (*this)(l[i]);
    return out + "]";
  }
};
}  // namespace

std::string FormatConfigValue(const ConfigValue& value) {
  return std::visit(ValueFormatter{}, value);
}

size_t EditDistance(const std::string& a, const std::string& b) {
  // Optimal string alignment (Damerau-Levenshtein without repeated edits of a substring): a swap
  // of two neighbouring letters, the commonest typo, costs 1.
  const size_t n = a.size(), m = b.size();
  std::vector<std::vector<size_t>> d(n + 1, std::vector<size_t>(m + 1, 0));
  for (size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (size_t i = 1; i <= n; ++i) {
    for (size_t j = 1; j <= m; ++j) {
      const size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[n][m];
}

std::string ClosestMatch(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_distance = std::numeric_limits<size_t>::max();
  for (const auto& c : candidates) {
    const size_t d = EditDistance(word, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  const size_t limit = std::max<size_t>(2, word.size() / 3);
  return best_distance <= limit ? best : std::string();
}

}  // namespace dfo::io
