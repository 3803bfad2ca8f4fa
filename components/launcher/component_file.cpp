// Component files of the launcher (see component_file.h).
#include "launcher/component_file.h"

#include <peis/error.h>
#include <peis/options.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

#include "common/yaml_reader.h"

namespace peis::launcher {
namespace fs = std::filesystem;
using components::YamlReader;

const char* toString(RestartPolicy policy) {
  switch (policy) {
    case RestartPolicy::Never:
      return "never";
    case RestartPolicy::OnFailure:
      return "on-failure";
    case RestartPolicy::Always:
      return "always";
  }
  return "?";
}

namespace {

// The --peis-* flags that take a value, as keys of `peis:`.
constexpr const char* kPeisValueKeys[] = {"id",        "name",    "port",           "connect",
                                          "set-tuple", "ecology", "discovery-port", "liveness-ms",
                                          "max-data"};

std::string knownPeisKeys() {
  std::string list;
  for (const char* key : kPeisValueKeys) list += std::string(list.empty() ? "" : ", ") + key;
  return list + ", no-discovery";
}

std::chrono::milliseconds seconds(const YamlReader& yaml, const YAML::Node& map, const char* key,
                                  std::chrono::milliseconds fallback, double low,
                                  const std::string& what) {
  const YAML::Node child = map[key];
  if (!child) return fallback;
  const double value = yaml.numberIn(child, low, 86400, what);
  return std::chrono::milliseconds(static_cast<long long>(std::llround(value * 1000)));
}

bool onOff(const YamlReader& yaml, const YAML::Node& node, const std::string& what) {
  const std::string value = yaml.text(node, what);
  if (value == "on" || value == "true" || value == "yes") return true;
  if (value == "off" || value == "false" || value == "no") return false;
  yaml.fail(node, what + " must be on or off, not '" + value + "'");
}

std::string absoluteFrom(const std::string& folder, const std::string& path) {
  return fs::absolute(fs::path(folder) / path).lexically_normal().string();
}

RestartRules parseRestart(const YamlReader& yaml, const YAML::Node& node) {
  RestartRules rules;
  if (!node) return rules;
  yaml.onlyKeys(node, {"policy", "max-restarts", "backoff", "max-backoff", "reset-after"},
                "restart");
  if (const YAML::Node policy = node["policy"]) {
    const std::string text = yaml.text(policy, "restart policy");
    if (text == "never")
      rules.policy = RestartPolicy::Never;
    else if (text == "on-failure")
      rules.policy = RestartPolicy::OnFailure;
    else if (text == "always")
      rules.policy = RestartPolicy::Always;
    else
      yaml.fail(policy, "restart policy must be never, on-failure or always, not '" + text + "'");
  }
  rules.maxRestarts = static_cast<int>(
      yaml.numberIn(node, "max-restarts", rules.maxRestarts, 0, 1000000, "max-restarts"));
  rules.backoff = seconds(yaml, node, "backoff", rules.backoff, 0, "backoff (seconds)");
  rules.maxBackoff =
      seconds(yaml, node, "max-backoff", rules.maxBackoff, 0, "max-backoff (seconds)");
  rules.resetAfter =
      seconds(yaml, node, "reset-after", rules.resetAfter, 0, "reset-after (seconds)");
  if (rules.maxBackoff < rules.backoff) yaml.fail(node, "max-backoff is less than backoff");
  return rules;
}

// `peis:` becomes --peis-* flags, checked as the program's Kernel would.
void parsePeis(const YamlReader& yaml, const YAML::Node& node, ComponentFile& c) {
  if (!node) return;
  if (!node.IsMap()) yaml.fail(node, "peis must be a mapping of --peis-* options");
  for (const auto& item : node) {
    const std::string key = item.first.Scalar();
    const YAML::Node& value = item.second;
    if (key == "no-discovery") {
      if (onOff(yaml, value, "peis no-discovery")) c.peisFlags.push_back("--peis-no-discovery");
      continue;
    }
    const bool known =
        std::find_if(std::begin(kPeisValueKeys), std::end(kPeisValueKeys),
                     [&](const char* k) { return key == k; }) != std::end(kPeisValueKeys);
    if (!known || !Options::isValueFlag("--peis-" + key))
      yaml.fail(item.first, "unknown key '" + key + "' in peis (known: " + knownPeisKeys() + ")");
    std::vector<std::string> values;
    if (key == "set-tuple" && value.IsMap()) {
      for (const auto& pair : value)
        values.push_back(yaml.text(pair.first, "a set-tuple key") + "=" +
                         yaml.text(pair.second, "a set-tuple value"));
    } else if (value.IsSequence()) {
      for (const auto& v : value) values.push_back(yaml.text(v, "peis " + key));
    } else {
      values.push_back(yaml.text(value, "peis " + key));
    }
    for (const auto& v : values) {
      c.peisFlags.push_back("--peis-" + key);
      c.peisFlags.push_back(v);
    }
    if (key == "name") c.peisName = values.back();
  }
  // The program's Kernel would refuse a bad value at its start: say so now.
  std::vector<std::string> args{"component"};
  args.insert(args.end(), c.peisFlags.begin(), c.peisFlags.end());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  int argc = static_cast<int>(args.size());
  try {
    Options::fromArgs(argc, argv.data());
  } catch (const Error& e) {
    std::string why = e.what();
    const std::string seeHelp = " (see --help)";
    if (why.size() > seeHelp.size() && why.ends_with(seeHelp))
      why.resize(why.size() - seeHelp.size());
    yaml.fail(node, "peis: " + why);
  }
}

}  // namespace

ComponentFile parseComponentFile(std::string_view text, const std::string& origin,
                                 const std::string& folder) {
  const YamlReader yaml(origin);
  const YAML::Node root = yaml.parse(text);
  if (!root.IsMap()) yaml.fail(root, "a component file must be a mapping");
  yaml.onlyKeys(root,
                {"name", "executable", "arguments", "peis", "environment", "working-directory",
                 "start", "restart", "stop-grace", "output-lines", "descriptor"},
                "the component file");
  ComponentFile c;
  c.file = origin;
  c.name = yaml.name(yaml.required(root, "name", "the component file"), "name");
  const YAML::Node executable = yaml.required(root, "executable", "the component file");
  c.executable = yaml.text(executable, "executable");
  c.executableLine = executable.Mark().line + 1;
  if (c.executable.empty()) yaml.fail(executable, "executable is empty");
  if (c.executable.find('/') != std::string::npos)
    c.executable = absoluteFrom(folder, c.executable);
  for (const auto& arg : yaml.list(root["arguments"], "arguments"))
    c.arguments.push_back(yaml.text(arg, "an argument"));
  parsePeis(yaml, root["peis"], c);
  if (const YAML::Node env = root["environment"]) {
    if (!env.IsMap()) yaml.fail(env, "environment must be a mapping of NAME: value");
    for (const auto& item : env) {
      const std::string name = yaml.text(item.first, "an environment name");
      if (name.empty() || name.find('=') != std::string::npos)
        yaml.fail(item.first, "environment name '" + name + "' is empty or has '='");
      c.environment.emplace_back(name, yaml.text(item.second, "environment " + name));
    }
  }
  c.workingDirectory = fs::absolute(folder).lexically_normal().string();
  if (const YAML::Node dir = root["working-directory"])
    c.workingDirectory = absoluteFrom(folder, yaml.text(dir, "working-directory"));
  if (const YAML::Node start = root["start"]) c.startOn = onOff(yaml, start, "start");
  c.restart = parseRestart(yaml, root["restart"]);
  c.restart.stopGrace =
      seconds(yaml, root, "stop-grace", c.restart.stopGrace, 0, "stop-grace (seconds)");
  c.outputLines =
      static_cast<int>(yaml.numberIn(root, "output-lines", c.outputLines, 0, 1000, "output-lines"));
  if (const YAML::Node descriptor = root["descriptor"])
    c.descriptor = absoluteFrom(folder, yaml.text(descriptor, "descriptor"));
  return c;
}

std::vector<ComponentFile> loadComponentFolder(const std::string& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec))
    throw Error(ErrorCode::InvalidConfig, folder + ": not a folder of component files");
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    const auto ext = entry.path().extension();
    if ((ext == ".yaml" || ext == ".yml") && !entry.is_directory()) files.push_back(entry.path());
  }
  if (ec) throw Error(ErrorCode::InvalidConfig, folder + ": " + ec.message());
  std::sort(files.begin(), files.end());
  std::vector<ComponentFile> result;
  std::map<std::string, std::string> fileOf;
  std::string problems;
  for (const auto& path : files) {
    try {
      auto c = parseComponentFile(components::readTextFile(path.string(), "component file"),
                                  path.string(), folder);
      if (const auto it = fileOf.find(c.name); it != fileOf.end()) {
        problems +=
            path.string() + ": component '" + c.name + "' is also defined in " + it->second + "\n";
        continue;
      }
      fileOf[c.name] = c.file;
      result.push_back(std::move(c));
    } catch (const Error& e) {
      problems += std::string(e.what()) + "\n";
    }
  }
  if (!problems.empty()) {
    problems.pop_back();
    throw Error(ErrorCode::InvalidConfig, problems);
  }
  return result;
}

std::string resolveExecutable(const std::string& executable, const std::string& path) {
  const auto runnable = [](const std::string& file) {
    std::error_code ec;
    return fs::is_regular_file(file, ec) && ::access(file.c_str(), X_OK) == 0;
  };
  if (executable.find('/') != std::string::npos) return runnable(executable) ? executable : "";
  std::stringstream dirs(path);
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const std::string candidate = (fs::path(dir.empty() ? "." : dir) / executable).string();
    if (runnable(candidate)) return candidate;
  }
  return "";
}

std::vector<std::string> commandLine(const ComponentFile& component, const std::string& program) {
  std::vector<std::string> argv{program};
  argv.insert(argv.end(), component.peisFlags.begin(), component.peisFlags.end());
  argv.insert(argv.end(), component.arguments.begin(), component.arguments.end());
  return argv;
}

}  // namespace peis::launcher
