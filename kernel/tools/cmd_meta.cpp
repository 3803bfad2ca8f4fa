// peis meta: point a meta tuple at a tuple.
#include <iostream>

#include "command.h"
#include "lookup.h"
#include "output.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  expectArguments(args, 2, 2, "OWNER.METAKEY TARGET_OWNER.TARGET_KEY");
  const auto meta = parseFullName(args.positional[0]);
  const auto target = parseFullName(args.positional[1]);
  const auto deadline = deadlineIn(args.seconds("--timeout").value_or(5.0));
  const auto targetOwner = resolvePeis(kernel, target.owner, deadline);
  const auto metaOwner = reachableOwner(kernel, meta.owner, deadline);
  kernel.setMeta(metaOwner, meta.key, targetOwner, target.key);
  if (args.has("--json")) {
    std::cout << "{\"meta\":" << json::quote(fullName(metaOwner, meta.key))
              << ",\"target\":" << json::quote(fullName(targetOwner, target.key)) << "}\n";
  }
  return 0;
}

}  // namespace

Command metaCommand() {
  return {"meta",
          "meta OWNER.METAKEY TARGET_OWNER.TARGET_KEY",
          "point a meta tuple at a tuple",
          "Writes '<target id>.<target key>' (application/x-peis-meta) to the meta\n"
          "tuple and exits once its owner accepted it. Names are resolved here, so\n"
          "the meta tuple always holds an id. --timeout (5 s) bounds the name\n"
          "resolution and the wait for the meta tuple's owner.",
          {"--timeout", "--json"},
          true,
          run};
}

}  // namespace peis::cli
