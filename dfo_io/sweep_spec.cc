#include "dfo_io/sweep_spec.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "dfo_core/error.h"
#include "dfo_io/file_reader.h"
#include "dfo_io/config.h"
#include "dfo_io/config_schema.h"

namespace dfo::io {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kTopKeys = {"base_config", "output", "sequences", "grid", "list",
                                           "set",         "parallel", "rank_by", "slurm"};
const std::vector<std::string> kSequenceKeys = {"name", "config", "set"};
const std::vector<std::string> kSlurmKeys = {"partition", "time", "cpus_per_task", "mem",
                                             "account",   "qos",  "max_parallel",  "extra"};

int Line(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? 0 : mark.line + 1;
}

// A count that may exceed every integer type, as an integer when it is exact.
std::string FormatCount(double n) {
  if (n < 1e15) return std::to_string(static_cast<long long>(n));
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g", n);
  return text;
}

// Reads one sweep file; every error names the file and line.
class SweepParser {
 public:
  SweepParser(std::string name, std::string folder)
      : name_(std::move(name)), folder_(std::move(folder)), check_config_(DfoSchema()) {}

  SweepSpec Parse(const std::string& text) {
    YAML::Node root;
    try {
      root = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      throw ConfigError(Where(e.mark.is_null() ? 0 : e.mark.line + 1) +
                        ": malformed YAML: " + e.msg);
    }
    if (!root.IsMap()) {
      Fail(Line(root), "the top level must be a mapping (base_config, sequences, grid, ...)");
    }
    SweepSpec spec;
    spec.path = name_;
    spec.output = "out/" + fs::path(name_).stem().string();
    std::map<std::string, YAML::Node> top = Keys(root, kTopKeys, "sweep key");
    if (top.count("base_config")) {
      spec.base_config = ConfigPath(top["base_config"], "base_config");
    }
    if (top.count("output")) spec.output = String(top["output"], "output");
    if (spec.output.empty()) Fail(Line(top["output"]), "output must name a folder");
    if (top.count("set")) spec.common = Overrides(top["set"], "set");
    if (top.count("parallel")) spec.parallel = Int(top["parallel"], "parallel", 0);
    if (top.count("rank_by")) {
      spec.rank_by = String(top["rank_by"], "rank_by");
      if (spec.rank_by != "auto" && spec.rank_by != "frontend" && spec.rank_by != "windowed") {
        Fail(Line(top["rank_by"]), "rank_by = '" + spec.rank_by +
                                       "' violates one of auto|frontend|windowed");
      }
    }
    if (top.count("slurm")) spec.slurm = Slurm(top["slurm"]);
    if (!top.count("sequences")) {
      Fail(Line(root), "no 'sequences': name at least one sequence (- name: ..., set: {...})");
    }
    spec.sequences = Sequences(top["sequences"]);
    std::vector<std::vector<SweepOverride>> settings;
    if (top.count("grid")) settings = Grid(top["grid"], &spec.swept_keys);
    if (top.count("list")) {
      for (auto& s : List(top["list"], &spec.swept_keys)) settings.push_back(std::move(s));
    }
    if (settings.empty()) settings.emplace_back();  // one run per sequence with the base settings
    const double runs = static_cast<double>(settings.size()) * spec.sequences.size();
    if (runs > kMaxSweepRuns) {
      Fail(Line(root), FormatCount(runs) + " runs (" + std::to_string(settings.size()) +
                           " settings x " + std::to_string(spec.sequences.size()) +
                           " sequences); a sweep runs at most " + std::to_string(kMaxSweepRuns));
    }
    spec.settings = Settings(settings, spec.swept_keys);
    return spec;
  }

 private:
  std::string Where(int line) const {
    return line > 0 ? name_ + ":" + std::to_string(line) : name_;
  }
  [[noreturn]] void Fail(int line, const std::string& what) const {
    throw ConfigError(Where(line) + ": " + what);
  }

  // The members of a mapping, each key checked against `allowed` (with a suggestion).
  std::map<std::string, YAML::Node> Keys(const YAML::Node& map,
                                         const std::vector<std::string>& allowed,
                                         const std::string& what) const {
    std::map<std::string, YAML::Node> out;
    for (const auto& item : map) {
      const std::string key = item.first.Scalar();
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        const std::string best = ClosestMatch(key, allowed);
        std::string known;
        for (const auto& a : allowed) known += (known.empty() ? "" : ", ") + a;
        Fail(Line(item.first), "unknown " + what + " '" + key + "'" +
                                   (best.empty() ? " (known: " + known + ")"
                                                 : " (did you mean '" + best + "'?)"));
      }
      if (out.count(key)) Fail(Line(item.first), what + " '" + key + "' appears twice");
      out[key] = item.second;
    }
    return out;
  }

  std::string String(const YAML::Node& node, const std::string& key) const {
    if (node.IsNull()) return "";
    if (!node.IsScalar()) Fail(Line(node), key + ": expected a string, found a " + Kind(node));
    return node.Scalar();
  }

  int Int(const YAML::Node& node, const std::string& key, int min) const {
    int value = 0;
    if (!node.IsScalar() || !YAML::convert<int>::decode(node, value)) {
      Fail(Line(node), key + ": expected an integer, found " +
                           (node.IsScalar() ? "'" + node.Scalar() + "'" : "a " + Kind(node)));
    }
    if (value < min) {
      Fail(Line(node), key + " = " + std::to_string(value) + " violates >= " + std::to_string(min));
    }
    return value;
  }

  static std::string Kind(const YAML::Node& node) {
    return node.IsMap() ? "mapping" : node.IsSequence() ? "list" : node.IsNull() ? "null" : "value";
  }

  // A configuration file named in the sweep: resolved against the sweep file's folder and checked
  // to load (its own errors name its file and line).
  std::string ConfigPath(const YAML::Node& node, const std::string& key) {
    const std::string given = String(node, key);
    if (given.empty()) return "";
    const fs::path p(given);
    const std::string path = p.is_absolute() || folder_.empty() ? given : (fs::path(folder_) / p)
                                                                             .lexically_normal()
                                                                             .string();
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) {
      Fail(Line(node), key + ": configuration file not found: " + path +
                           " (config paths are relative to the sweep file's folder)");
    }
    LoadConfig(path, DfoSchema());
    return path;
  }

  // The text --set gets for a value: a scalar as written, a list as "[a, b]".
  std::string ValueText(const YAML::Node& node, const std::string& key) const {
    if (node.IsScalar()) return node.Scalar();
    if (node.IsSequence()) {
      std::string text = "[";
      for (size_t i = 0; i < node.size(); ++i) {
        if (!node[i].IsScalar()) Fail(Line(node[i]), key + ": expected a value, found a list");
        text += (i ? ", " : "") + node[i].Scalar();
      }
      return text + "]";
    }
    Fail(Line(node), key + ": expected a value, found a " + Kind(node));
  }

  // One override, checked against dfo_run's schema: key, type and range.
  SweepOverride Override(const std::string& key, const YAML::Node& value, int line) {
    const ConfigSchema& schema = DfoSchema();
    if (schema.Find(key) == nullptr) {
      const std::string best = ClosestMatch(key, schema.KeyPaths());
      Fail(line, "unknown dfo_run key '" + key + "'" +
                     (best.empty() ? " (dfo_run --print-config lists every key)"
                                   : " (did you mean '" + best + "'?)"));
    }
    if (key == "run.output_dir") {
      Fail(line, "run.output_dir is chosen by the sweep (<output>/runs/<sequence>/<setting>)");
    }
    SweepOverride o{key, ValueText(value, key), line};
    try {
      check_config_.ApplyOverride(o.Text());
    } catch (const ConfigError& e) {
      Fail(line, e.what());
    }
    return o;
  }

  std::vector<SweepOverride> Overrides(const YAML::Node& map, const std::string& what) {
    if (map.IsNull()) return {};
    if (!map.IsMap()) {
      Fail(Line(map), what + ": expected a mapping of dfo_run keys (section.key: value), found a " +
                          Kind(map));
    }
    std::vector<SweepOverride> out;
    std::set<std::string> seen;
    for (const auto& item : map) {
      const std::string key = item.first.Scalar();
      if (!seen.insert(key).second) Fail(Line(item.first), "key '" + key + "' appears twice");
      out.push_back(Override(key, item.second, Line(item.first)));
    }
    return out;
  }

  std::vector<SweepSequence> Sequences(const YAML::Node& list) {
    if (!list.IsSequence() || list.size() == 0) {
      Fail(Line(list), "sequences: expected a non-empty list of sequences (- name: ..., set: "
                       "{dataset.path: ...})");
    }
    std::vector<SweepSequence> out;
    std::map<std::string, int> names;
    for (const YAML::Node& item : list) {
      if (!item.IsMap()) Fail(Line(item), "a sequence must be a mapping (name, config, set)");
      std::map<std::string, YAML::Node> keys = Keys(item, kSequenceKeys, "sequence key");
      SweepSequence s;
      if (!keys.count("name")) Fail(Line(item), "a sequence needs a name");
      s.name = String(keys["name"], "name");
      if (s.name.empty() || s.name == "." || s.name == ".." ||
          s.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"
                                   "._-") != std::string::npos) {
        Fail(Line(keys["name"]), "sequence name '" + s.name +
                                     "' must be a folder name of letters, digits, '.', '_', '-'");
      }
      if (names.count(s.name)) {
        Fail(Line(keys["name"]), "sequence '" + s.name + "' is named twice (first at line " +
                                     std::to_string(names[s.name]) + ")");
      }
      names[s.name] = Line(keys["name"]);
      if (keys.count("config")) s.config = ConfigPath(keys["config"], "config");
      if (keys.count("set")) s.overrides = Overrides(keys["set"], "set");
      out.push_back(std::move(s));
    }
    return out;
  }

  SweepSlurm Slurm(const YAML::Node& map) const {
    SweepSlurm s;
    if (map.IsNull()) return s;
    if (!map.IsMap()) Fail(Line(map), "slurm: expected a mapping (partition, time, ...)");
    std::map<std::string, YAML::Node> keys = Keys(map, kSlurmKeys, "slurm key");
    const auto text = [&](const char* key, std::string* out) {
      if (keys.count(key)) *out = String(keys[key], std::string("slurm.") + key);
    };
    text("partition", &s.partition);
    text("time", &s.time);
    text("mem", &s.mem);
    text("account", &s.account);
    text("qos", &s.qos);
    if (keys.count("cpus_per_task")) s.cpus_per_task = Int(keys["cpus_per_task"], "slurm.cpus_per_task", 0);
    if (keys.count("max_parallel")) s.max_parallel = Int(keys["max_parallel"], "slurm.max_parallel", 0);
    if (keys.count("extra")) {
      const YAML::Node& extra = keys["extra"];
      if (!extra.IsSequence()) {
        Fail(Line(extra), "slurm.extra: expected a list of sbatch options like [--qos=short]");
      }
      for (const YAML::Node& option : extra) {
        const std::string o = String(option, "slurm.extra");
        if (o.rfind("--", 0) != 0 || o.find('\n') != std::string::npos) {
          Fail(Line(option), "slurm.extra: '" + o + "' is not an sbatch option (--name=value)");
        }
        s.extra.push_back(o);
      }
    }
    return s;
  }

  void NoteKey(const std::string& key, std::vector<std::string>* keys) const {
    if (std::find(keys->begin(), keys->end(), key) == keys->end()) keys->push_back(key);
  }

  // Every combination of the grid's values, the last key varying fastest.
  std::vector<std::vector<SweepOverride>> Grid(const YAML::Node& map,
                                               std::vector<std::string>* keys) {
    if (!map.IsMap()) {
      Fail(Line(map), "grid: expected a mapping of dfo_run keys to lists of values, found a " +
                          Kind(map));
    }
    std::vector<std::vector<SweepOverride>> axes;
    std::set<std::string> seen;
    for (const auto& item : map) {
      const std::string key = item.first.Scalar();
      const int line = Line(item.first);
      if (!seen.insert(key).second) Fail(line, "grid key '" + key + "' appears twice");
      std::vector<SweepOverride> values;
      if (item.second.IsSequence()) {
        if (item.second.size() == 0) Fail(line, "grid key '" + key + "' has no values");
        for (const YAML::Node& v : item.second) values.push_back(Override(key, v, Line(v)));
      } else {
        values.push_back(Override(key, item.second, line));
      }
      std::set<std::string> texts;
      for (const auto& v : values) {
        if (!texts.insert(v.value).second) {
          Fail(v.line, "grid key '" + key + "' lists the value " + v.value + " twice");
        }
      }
      NoteKey(key, keys);
      axes.push_back(std::move(values));
    }
    // The product is checked before it is built: a grid of a million runs is a typo, not a sweep.
    double product = 1.0;
    for (const auto& axis : axes) product *= static_cast<double>(axis.size());
    if (product > kMaxSweepRuns) {
      Fail(Line(map), "grid: " + FormatCount(product) + " combinations; a sweep runs at most " +
                          std::to_string(kMaxSweepRuns));
    }
    std::vector<std::vector<SweepOverride>> combos(1);
    for (const auto& axis : axes) {
      std::vector<std::vector<SweepOverride>> next;
      for (const auto& combo : combos) {
        for (const auto& value : axis) {
          next.push_back(combo);
          next.back().push_back(value);
        }
      }
      combos = std::move(next);
    }
    return axes.empty() ? std::vector<std::vector<SweepOverride>>{} : combos;
  }

  std::vector<std::vector<SweepOverride>> List(const YAML::Node& list,
                                               std::vector<std::string>* keys) {
    if (!list.IsSequence()) {
      Fail(Line(list), "list: expected a list of settings (- {section.key: value, ...}), found a " +
                           Kind(list));
    }
    std::vector<std::vector<SweepOverride>> out;
    for (const YAML::Node& item : list) {
      if (!item.IsMap() || item.size() == 0) {
        Fail(Line(item), "list: each setting must be a non-empty mapping {section.key: value}");
      }
      out.push_back(Overrides(item, "list"));
      for (const auto& o : out.back()) NoteKey(o.key, keys);
    }
    return out;
  }

  static std::string ShortName(const std::string& key, const std::vector<std::string>& keys) {
    const std::string tail = key.substr(key.find('.') + 1);
    for (const auto& other : keys) {
      if (other != key && other.substr(other.find('.') + 1) == tail) return key;
    }
    return tail;
  }

  std::vector<SweepSetting> Settings(const std::vector<std::vector<SweepOverride>>& combos,
                                     const std::vector<std::string>& keys) const {
    std::vector<SweepSetting> out;
    std::map<std::string, int> folders;
    for (const auto& combo : combos) {
      SweepSetting s;
      s.values = combo;
      for (const auto& v : combo) {
        const std::string pair = ShortName(v.key, keys) + "=" + v.value;
        s.label += (s.label.empty() ? "" : ", ") + pair;
        std::string safe = pair;
        for (char& c : safe) {
          if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '=' &&
              c != '-' && c != '+') {
            c = '_';
          }
        }
        s.folder += (s.folder.empty() ? "" : "__") + safe;
      }
      if (s.values.empty()) s.label = s.folder = "base";
      if (s.folder.size() > 200) s.folder = "setting_" + std::to_string(out.size());
      const int line = combo.empty() ? 0 : combo.front().line;
      if (folders.count(s.folder)) {
        Fail(line, "setting " + s.label + " is the same as the one at line " +
                       std::to_string(folders[s.folder]));
      }
      folders[s.folder] = line;
      out.push_back(std::move(s));
    }
    return out;
  }

  std::string name_;
  std::string folder_;
  Config check_config_;  // scratch configuration to check overrides on
};

}  // namespace

SweepSpec LoadSweepSpecFromString(const std::string& text, const std::string& name,
                                  const std::string& folder) {
  return SweepParser(name, folder).Parse(text);
}

SweepSpec LoadSweepSpec(const std::string& path) {
  return LoadSweepSpecFromString(ReadWholeFile(path, "sweep file", kMaxTextFileBytes), path,
                                 fs::path(path).parent_path().string());
}

std::vector<SweepRun> ExpandSweep(const SweepSpec& spec) {
  std::vector<SweepRun> runs;
  for (size_t s = 0; s < spec.settings.size(); ++s) {
    for (size_t q = 0; q < spec.sequences.size(); ++q) {
      const SweepSequence& sequence = spec.sequences[q];
      const SweepSetting& setting = spec.settings[s];
      SweepRun run;
      run.index = static_cast<int>(runs.size());
      run.setting = static_cast<int>(s);
      run.sequence = static_cast<int>(q);
      run.config = sequence.config.empty() ? spec.base_config : sequence.config;
      run.output_dir = (fs::path(spec.output) / "runs" / sequence.name / setting.folder).string();
      run.overrides.push_back("run.progress=none");
      for (const auto* list : {&spec.common, &sequence.overrides, &setting.values}) {
        for (const SweepOverride& o : *list) run.overrides.push_back(o.Text());
      }
      run.overrides.push_back("run.output_dir=" + run.output_dir);
      try {
        const Config config = LoadConfig(run.config, DfoSchema(), run.overrides);
        const int threads = config.GetInt("run.threads");
        run.threads = threads > 0 ? threads
                                  : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
      } catch (const ConfigError& e) {
        throw ConfigError(spec.path + ": run " + sequence.name + " / " + setting.label + ": " +
                          e.what());
      }
      runs.push_back(std::move(run));
    }
  }
  return runs;
}

}  // namespace dfo::io
