// peis set: write a tuple of any PEIS.
#include <iostream>

#include "command.h"
#include "lookup.h"
#include "output.h"
#include "value_input.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  expectArguments(args, 2, 2, "OWNER.KEY VALUE");
  const auto name = parseFullName(args.positional[0]);
  const auto value = readValue(args.positional[1], args.has("--literal"), std::cin);
  WriteOptions options;
  if (value.binary) {
    options.encoding = Encoding::Binary;
    options.mimetype = "application/octet-stream";
  }
  if (auto mimetype = args.text("--mimetype")) options.mimetype = *mimetype;
  if (auto ttl = args.seconds("--ttl")) {
    if (*ttl <= 0) throw UsageError("--ttl needs a positive number of seconds");
    options.ttl = std::chrono::microseconds(static_cast<long long>(*ttl * 1e6));
  }
  const auto deadline = deadlineIn(args.seconds("--timeout").value_or(5.0));
  const auto owner = resolvePeis(kernel, name.owner, deadline);
  if (!waitUntil([&] { return reachable(kernel, owner); }, deadline)) {
    std::cerr << "peis: PEIS " << owner << " is not reachable\n";
    return 1;
  }
  const auto tuple = kernel.set(owner, name.key, value.data, options);
  if (args.has("--json")) {
    std::cout << "{\"owner\":" << owner << ",\"key\":" << jsonString(name.key)
              << ",\"seqno\":" << tuple.seqno << "}\n";
  }
  return 0;
}

}  // namespace

Command setCommand() {
  return {"set",
          "set OWNER.KEY VALUE",
          "write a tuple; exit 0 once its owner accepted it",
          "VALUE is taken as written, or read from stdin (-) or a file (@FILE);\n"
          "text read so loses one trailing newline, data that is not text is sent\n"
          "as binary (application/octet-stream unless --mimetype). --ttl S makes the\n"
          "value expire S seconds after the owner accepted it. Waits at most\n"
          "--timeout (5 s) for the owner to be reachable.",
          {"--timeout", "--json", "--ttl", "--mimetype", "--literal"},
          true,
          run};
}

}  // namespace peis::cli
