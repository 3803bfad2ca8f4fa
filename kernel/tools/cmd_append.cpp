// peis append: add bytes to the end of a tuple of any PEIS, atomically.
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
  std::optional<std::uint64_t> ifSeqno;
  if (auto n = args.number("--if-seqno")) ifSeqno = static_cast<std::uint64_t>(*n);
  const auto deadline = deadlineIn(args.seconds("--timeout").value_or(5.0));
  const auto owner = resolvePeis(kernel, name.owner, deadline);
  if (!waitUntil([&] { return reachable(kernel, owner); }, deadline)) {
    std::cerr << "peis: PEIS " << owner << " is not reachable\n";
    return 1;
  }
  const auto tuple = kernel.append(owner, name.key, value.data, ifSeqno);
  if (args.has("--json")) {
    std::cout << "{\"owner\":" << owner << ",\"key\":" << jsonString(name.key)
              << ",\"seqno\":" << tuple.seqno << "}\n";
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
