// peis-config: the configuration planner on the command line (`peis config …`
// runs it, as git runs git-<command>). Offline subcommands work on a saved
// model file; the online ones (model, apply, withdraw, show, events, and
// plan without --model) join the ecology as a tool PEIS
// (programs/config_online.h).
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "monitor/goal_tuples.h"
#include "peis/error.h"
#include "peis/meta/planner.h"
#include "peis/options.h"
#include "programs/config_online.h"

namespace {

struct Subcommand {
  const char* name;
  const char* usage;
  const char* summary;
  int (*run)(const std::vector<std::string>& args);
};

int usageError(const std::string& message) {
  std::cerr << "peis-config: " << message << " (see peis-config --help)\n";
  return 2;
}

// plan GOAL… [--model FILE] [--goals FILE] [--json] [--time-limit MS] [--first] [--wait S]
int plan(const std::vector<std::string>& args) {
  std::string modelFile, goalsFile;
  bool json = false, first = false;
  long timeLimitMs = 1000;
  double waitSeconds = 3;
  std::vector<std::string> goalArgs;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const auto& a = args[i];
    auto value = [&](const char* what) -> std::string {
      if (i + 1 >= args.size()) throw std::invalid_argument(std::string(what) + " needs a value");
      return args[++i];
    };
    if (a == "--model") {
      modelFile = value("--model");
    } else if (a == "--goals") {
      goalsFile = value("--goals");
    } else if (a == "--json") {
      json = true;
    } else if (a == "--first") {
      first = true;
    } else if (a == "--time-limit") {
      const auto text = value("--time-limit");
      char* end = nullptr;
      timeLimitMs = std::strtol(text.c_str(), &end, 10);
      if (*end || timeLimitMs < 0) throw std::invalid_argument("--time-limit takes milliseconds");
    } else if (a == "--wait") {
      const auto text = value("--wait");
      char* end = nullptr;
      waitSeconds = std::strtod(text.c_str(), &end);
      if (*end || !(waitSeconds >= 0) || waitSeconds > 86400)
        throw std::invalid_argument("--wait takes seconds from 0 to 86400");
    } else if (a.rfind("--", 0) == 0) {
      throw std::invalid_argument("unknown option " + a);
    } else {
      goalArgs.push_back(a);
    }
  }
  if (modelFile.empty())
    return peis::meta::cli::planLive(goalArgs, goalsFile, json, timeLimitMs, first, waitSeconds);
  auto goals = peis::meta::Goals::fromArguments(goalArgs);
  if (!goalsFile.empty()) {
    peis::meta::mergeGoals(goals, peis::meta::Goals::fromFile(goalsFile));
  }
  if (goals.empty()) throw std::invalid_argument("no goal given");
  peis::meta::ConfigurationPlanner planner(peis::meta::Model::fromFile(modelFile));
  peis::meta::PlanOptions options;
  options.timeLimit = std::chrono::milliseconds(timeLimitMs);
  options.firstSolutionOnly = first;
  const auto result = planner.plan(goals, options);
  std::cout << (json ? peis::meta::formatJson(result) + "\n" : peis::meta::formatText(result));
  return result.ok() ? 0 : 1;
}

// check --model FILE: reads a model file (and the descriptors it names).
int check(const std::vector<std::string>& args) {
  if (args.size() != 2 || args[0] != "--model")
    throw std::invalid_argument("usage: check --model FILE");
  const auto model = peis::meta::Model::fromFile(args[1]);
  std::size_t functionalities = 0;
  for (const auto& p : model.peis) {
    for (const auto& d : p.components) functionalities += d.functionalities.size();
  }
  std::cout << args[1] << ": " << model.peis.size() << " PEIS, " << functionalities
            << " functionalities, " << model.facts.size() << " facts\n";
  return 0;
}

const std::vector<Subcommand> kSubcommands = {
    {"plan",
     "plan GOAL… [--model FILE] [--goals FILE] [--json] [--time-limit MS] [--first] [--wait S]",
     "plan the cheapest configuration for the goals on a saved model (or the live one)", plan},
    {"check", "check --model FILE", "read a model file and its descriptors, report errors", check},
    {"model", "model [--json | --yaml | --save FILE] [--local] [--wait S]",
     "print the live model of the ecology (the configurator's, else introspected here)",
     peis::meta::cli::model},
    {"apply",
     "apply GOAL… [--goals FILE] [--as LABEL] [--dry-run] [--json] [--wait S] [--timeout S]",
     "plan and deploy: through the running configurator (its goal tuple config.goal.LABEL), "
     "else once from here",
     peis::meta::cli::apply},
    {"withdraw", "withdraw [--as LABEL] [--wait S]",
     "withdraw the goals that apply posted to the configurator", peis::meta::cli::withdraw},
    {"show", "show [--json] [--wait S]", "print the configuration deployed now",
     peis::meta::cli::show},
    {"events", "events [--follow] [--count N] [--timeout S] [--from PEIS] [--json] [--wait S]",
     "print the configurator's events in order (with --follow, new ones as they come)",
     peis::meta::cli::events},
};

void help() {
  std::cout << "Usage: peis-config SUBCOMMAND [ARGS]   (also: peis config SUBCOMMAND …)\n\n";
  for (const auto& s : kSubcommands)
    std::cout << "  " << s.usage << "\n      " << s.summary << "\n";
  std::cout << R"(
Goals (one per argument):
  TERM                  information that must be produced, e.g. 'activity(johanna,kitchen)'
  TERM@PEIS.KEY         ... and delivered to a meta input, e.g. 'position(vac)@vac.mi-position'
  run:PEIS/COMPONENT/FUNCTIONALITY[{?var=value,…}]   a functionality that must run
  avoid:PEIS  avoid:SELECTOR   never plan on that PEIS / instance
  prefer:SELECTOR              the instance's own cost is waived when chosen

--time-limit MS (default 1000) bounds the search: the best configuration found
is printed with its lower bound. The online subcommands join the ecology
(--peis-* options and PEIS_* variables apply) and wait up to --wait S (3) for
its tuples. Exit status: 0 done (a configuration), 1 none or not deployed, 2
bad arguments or input. Files and their schema: docs/configuration.md.
)";
}

}  // namespace

int main(int argc, char** argv) {
  try {
    peis::meta::cli::setPeisOptions(peis::Options::fromArgs(argc, argv));
  } catch (const peis::Error& e) {
    return usageError(e.what());
  }
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    help();
    return args.empty() ? 2 : 0;
  }
  for (const auto& s : kSubcommands) {
    if (args[0] != s.name) continue;
    std::vector<std::string> rest(args.begin() + 1, args.end());
    for (const auto& a : rest) {
      if (a == "--help" || a == "-h") {
        std::cout << "Usage: peis-config " << s.usage << "\n" << s.summary << "\n";
        return 0;
      }
    }
    try {
      return s.run(rest);
    } catch (const std::invalid_argument& e) {
      return usageError(e.what());
    } catch (const peis::Error& e) {
      std::cerr << "peis-config: " << e.what() << "\n";
      return 2;
    }
  }
  return usageError("unknown subcommand '" + args[0] + "'");
}
