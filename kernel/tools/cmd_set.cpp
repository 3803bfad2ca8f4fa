// peis set: write a tuple of any PEIS.
#include <iostream>

#include "command.h"
#include "output.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  const auto ttl = args.seconds("--ttl");
  if (ttl && *ttl <= 0) throw UsageError("--ttl needs a positive number of seconds");
  const auto request = readWriteRequest(kernel, args);
  WriteOptions options;
  if (request.value.binary) {
    options.encoding = Encoding::Binary;
    options.mimetype = "application/octet-stream";
  }
  if (auto mimetype = args.text("--mimetype")) options.mimetype = *mimetype;
  if (ttl) options.ttl = std::chrono::microseconds(static_cast<long long>(*ttl * 1e6));
  const auto tuple = kernel.set(request.owner, request.key, request.value.data, options);
  if (args.has("--json")) {
    std::cout << writeResultJson(request.owner, request.key, tuple.seqno) << "\n";
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
