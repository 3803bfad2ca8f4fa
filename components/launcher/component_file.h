// ComponentFile: one component the launcher (peis-init) can start, read from
// a YAML file of its folder: the program, its arguments and PEIS options, its
// environment and working directory, the restart policy and the initial
// state. Parsing is pure (text in, value or an error naming file:line out);
// the schema is in docs/operating.md.
#pragma once

#include <chrono>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace peis::launcher {

enum class RestartPolicy { Never, OnFailure, Always };

const char* toString(RestartPolicy policy);

// When a component that ended by itself is started again, and how a stop goes.
struct RestartRules {
  RestartPolicy policy = RestartPolicy::OnFailure;
  int maxRestarts = 5;                          // restarts in a row before the component is failed
  std::chrono::milliseconds backoff{1000};      // before the first restart; doubled each time
  std::chrono::milliseconds maxBackoff{30000};  // the longest wait between restarts
  std::chrono::milliseconds resetAfter{10000};  // a run this long ends a row of restarts
  std::chrono::milliseconds stopGrace{5000};    // SIGTERM, then SIGKILL after this
};

struct ComponentFile {
  std::string name;        // one key part: components.<name>.*
  std::string file;        // where it was read from
  int executableLine = 0;  // the line of `executable:` in `file`, for errors
  std::string executable;  // as written: a path (with '/') or a program name
  std::vector<std::string> arguments;
  std::vector<std::string> peisFlags;  // --peis-* flags from `peis:`, in file order
  std::string peisName;                // the PEIS name it joins as (`peis: name`), or empty
  std::vector<std::pair<std::string, std::string>> environment;
  std::string workingDirectory;  // absolute: the file's folder unless the file says otherwise
  bool startOn = false;          // the initial reqState
  RestartRules restart;
  int outputLines = 20;    // last lines of stdout and stderr kept as tuples
  std::string descriptor;  // a functionality descriptor file (absolute), or empty
};

// Parses one component file. `folder` is the file's folder: relative paths
// in the file are taken from there. Throws Error(InvalidConfig) with
// "origin:line: problem".
ComponentFile parseComponentFile(std::string_view text, const std::string& origin,
                                 const std::string& folder);

// Reads every *.yaml and *.yml file of `folder` (sorted by name). Every
// problem of every file is collected; if there is any, throws
// Error(InvalidConfig) with one line per problem. Two files naming the same
// component are an error.
std::vector<ComponentFile> loadComponentFolder(const std::string& folder);

// The program to run: a name without '/' looked up in `path` (a PATH value),
// a path as it is (relative ones were made absolute by the parser). Empty
// when there is no such executable file.
std::string resolveExecutable(const std::string& executable, const std::string& path);

// argv of a run: the program, the --peis-* flags, then the arguments.
std::vector<std::string> commandLine(const ComponentFile& component, const std::string& program);

}  // namespace peis::launcher
