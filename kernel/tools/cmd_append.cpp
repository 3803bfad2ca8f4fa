// peis append: add bytes to the end of a tuple of any PEIS, atomically.
#include <iostream>

#include "command.h"
#include "output.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  std::optional<std::uint64_t> ifSeqno;
  if (auto n = args.number("--if-seqno")) ifSeqno = static_cast<std::uint64_t>(*n);
  const auto request = readWriteRequest(kernel, args);
  const auto tuple = kernel.append(request.owner, request.key, request.value.data, ifSeqno);
  if (args.has("--json")) {
    std::cout << writeResultJson(request.owner, request.key, tuple.seqno) << "\n";
  }
  return 0;
}

}  // namespace

Command appendCommand() {
  return {"append",
          "append OWNER.KEY VALUE",
          "append to a tuple (created when absent); exit 0 once its owner did",
          "The owner appends VALUE (as for set: -, @FILE, --literal) to the tuple's\n"
          "data atomically, keeping its mimetype. With --if-seqno N only if the\n"
          "tuple's seqno is still N (0: absent), else exit 1 (conflict).",
          {"--timeout", "--json", "--literal", "--if-seqno"},
          true,
          run};
}

}  // namespace peis::cli
