#include "apps/common/args.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <utility>

namespace dfo::apps {

namespace {

// Edit distance, for "did you mean".
size_t Distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

// "--x" or "-x" but not a negative number ("-3", "-.5").
bool LooksLikeOption(const std::string& text) {
  if (text.size() < 2 || text[0] != '-') return false;
  const char c = text[1] == '-' ? (text.size() > 2 ? text[2] : '\0') : text[1];
  return !(std::isdigit(static_cast<unsigned char>(c)) || c == '.');
}

}  // namespace

int64_t ParseIntArgument(const std::string& what, const std::string& text, int64_t lo, int64_t hi) {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  const bool whole = !text.empty() && end != nullptr && *end == '\0' &&
                     !std::isspace(static_cast<unsigned char>(text[0]));
  if (!whole || errno == ERANGE) {
    throw UsageError(what + ": '" + text + "' is not an integer (expected one in [" +
                     std::to_string(lo) + ", " + std::to_string(hi) + "])");
  }
  if (v < lo || v > hi) {
    throw UsageError(what + ": " + text + " is out of range (expected an integer in [" +
                     std::to_string(lo) + ", " + std::to_string(hi) + "])");
  }
  return v;
}

double ParseNumberArgument(const std::string& what, const std::string& text, double lo, double hi) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  const bool whole = !text.empty() && end != nullptr && *end == '\0' &&
                     !std::isspace(static_cast<unsigned char>(text[0]));
  const auto range = [&] {
    std::string r = "[";
    r += std::isfinite(lo) ? std::to_string(lo) : "-inf";
    r += ", ";
    r += std::isfinite(hi) ? std::to_string(hi) : "inf";
    return r + "]";
  };
  if (!whole || errno == ERANGE || !std::isfinite(v)) {
    throw UsageError(what + ": '" + text + "' is not a (finite) number");
  }
  if (v < lo || v > hi) {
    throw UsageError(what + ": " + text + " is out of range (expected a number in " + range() +
                     ")");
  }
  return v;
}

ArgParser::Option& ArgParser::Add(const std::string& name) {
  options_.push_back(Option{});
  options_.back().name = name;
  return options_.back();
}

const ArgParser::Option* ArgParser::Find(const std::string& name) const {
  for (const Option& o : options_) {
    if (o.name == name || (!o.alias.empty() && o.alias == name)) return &o;
  }
  return nullptr;
}

std::string ArgParser::Suggestion(const std::string& unknown) const {
  std::string best;
  size_t best_distance = 3;  // at most 2 edits away
  for (const Option& o : options_) {
    const size_t d = Distance(unknown, o.name);
    if (d < best_distance) {
      best_distance = d;
      best = o.name;
    }
  }
  return best.empty() ? "" : " (did you mean '" + best + "'?)";
}

ArgParser& ArgParser::Flag(const std::string& name, bool* target, const std::string& alias) {
  Option& o = Add(name);
  o.alias = alias;
  o.takes_value = false;
  o.flag = target;
  return *this;
}

ArgParser& ArgParser::Value(const std::string& name, std::string* target) {
  return Custom(name, [target](const std::string& v) { *target = v; });
}

ArgParser& ArgParser::Values(const std::string& name, std::vector<std::string>* target) {
  return Custom(
      name, [target](const std::string& v) { target->push_back(v); }, /*repeatable=*/true);
}

ArgParser& ArgParser::Int(const std::string& name, int* target, int lo, int hi) {
  return Custom(name, [=](const std::string& v) {
    *target = static_cast<int>(ParseIntArgument(name, v, lo, hi));
  });
}

ArgParser& ArgParser::Number(const std::string& name, double* target, double lo, double hi) {
  return Custom(name,
                [=](const std::string& v) { *target = ParseNumberArgument(name, v, lo, hi); });
}

ArgParser& ArgParser::Custom(const std::string& name, std::function<void(const std::string&)> take,
                             bool repeatable) {
  Option& o = Add(name);
  o.take = std::move(take);
  o.repeatable = repeatable;
  return *this;
}

ArgParser& ArgParser::Positional(const std::string& name, std::string* target, bool required) {
  positionals_.push_back(Positional_{name, target, required});
  return *this;
}

void ArgParser::Parse(int argc, char** argv, int first) {
  for (int i = first; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      if (const Option* o = Find(a); o != nullptr && o->flag != nullptr) {
        *o->flag = true;
        given_.insert(o->name);
        return;
      }
    }
  }
  size_t next_positional = 0;
  for (int i = first; i < argc; ++i) {
    const std::string arg = argv[i];
    if (!LooksLikeOption(arg) || arg == "-") {
      if (next_positional >= positionals_.size()) {
        throw UsageError(positionals_.empty()
                             ? "unexpected argument '" + arg + "' (this tool takes only options)"
                             : "unexpected argument '" + arg + "' after " +
                                   positionals_.back().name);
      }
      *positionals_[next_positional++].target = arg;
      continue;
    }
    std::string name = arg, value;
    bool inline_value = false;
    if (const size_t eq = arg.find('='); arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      name = arg.substr(0, eq);
      value = arg.substr(eq + 1);
      inline_value = true;
    }
    const Option* o = Find(name);
    if (o == nullptr) throw UsageError("unknown argument '" + name + "'" + Suggestion(name));
    if (!o->takes_value) {
      if (inline_value) throw UsageError(o->name + " takes no value, got '" + arg + "'");
      if (o->flag != nullptr) *o->flag = true;
      given_.insert(o->name);
      continue;
    }
    if (!inline_value) {
      if (i + 1 >= argc) throw UsageError(o->name + " needs a value");
      value = argv[++i];
      if (LooksLikeOption(value)) {
        throw UsageError(o->name + " needs a value, found the option '" + value + "'");
      }
    }
    if (value.empty()) throw UsageError(o->name + " needs a non-empty value");
    if (!o->repeatable && given_.count(o->name) != 0) {
      throw UsageError(o->name + " given twice ('" + first_values_[o->name] + "', then '" + value +
                       "'): give it once");
    }
    given_.insert(o->name);
    first_values_.emplace(o->name, value);
    o->take(value);
  }
  for (size_t k = next_positional; k < positionals_.size(); ++k) {
    if (positionals_[k].required) throw UsageError(positionals_[k].name + " is missing");
  }
}

}  // namespace dfo::apps
