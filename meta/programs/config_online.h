// The online subcommands of peis-config (`peis config model|apply|withdraw|
// show|events`, and `plan` without --model): each is a short-lived tool PEIS
// that joins the ecology, looks, acts through the running configurator when
// there is one, and leaves. docs/cli.md, "peis config".
#pragma once

#include <string>
#include <vector>

#include "peis/options.h"

namespace peis::meta::cli {

// The --peis-* options of the command line (set by main).
void setPeisOptions(const Options& options);

int model(const std::vector<std::string>& args);
int apply(const std::vector<std::string>& args);
int withdraw(const std::vector<std::string>& args);
int show(const std::vector<std::string>& args);
int events(const std::vector<std::string>& args);
// `plan GOAL…` on the live model (no --model).
int planLive(const std::vector<std::string>& goalArgs, const std::string& goalsFile, bool json,
             long timeLimitMs, bool first, double waitSeconds);

// Goals as goal-tuple lines (`TERM@PEIS.KEY`, `run:…`, `avoid:…`, `prefer:…`).
std::vector<std::string> goalLines(const std::vector<std::string>& goalArgs,
                                   const std::string& goalsFile);

}  // namespace peis::meta::cli
