// Unit tests of the layering check (layering.h): the table is read as
// written, and a forbidden include is found whichever way it is spelled.
#include "layering.h"

#include <catch2/catch.hpp>
#include <string>

using Catch::Matchers::Contains;
using namespace peis::layering;

namespace {

const std::string kTable = R"(Some prose.

<!-- layering:begin -->
| folder | ours | outside |
|---|---|---|
| `kernel/include/` | — | C, C++ |
| `kernel/src/` | `kernel/include/` | C, C++, system, Boost |
| `meta/`, `components/` | `kernel/include/`, `component/include/` | C, C++, system |
| `bridge/` | `kernel/include/`, `tiny/include/tiny_tuple.h` | C++ |
| `tiny/src/` | `tiny/include/` | C |
| `tests/` | `tests/support/` | C++, Catch2 |
| `tests/kernel/` | `kernel/`, `tests/support/` | C++, Catch2 |
| `component/include/` | `kernel/include/` | C++ |
| `tiny/include/` | — | C |
| `bench/peers/` | — | C++, CycloneDDS, ZeroMQ |
<!-- layering:end -->
)";

// A small tree that keeps the table (checked below): each test adds the
// file under test.
SourceTree baseTree() {
  return {{"kernel/include/peis/kernel.h", "#pragma once\n#include <string>\n"},
          {"kernel/src/tuple_space.h", "#include \"peis/kernel.h\"\n#include <boost/asio.hpp>\n"},
          {"kernel/src/log.h", "#pragma once\n"},
          {"component/include/peis/component.h", "#include \"peis/kernel.h\"\n"},
          {"tiny/include/tiny_tuple.h", "#include <stdint.h>\n"},
          {"tiny/include/tiny_kernel.h", "#include \"tiny_tuple.h\"\n"},
          {"tests/support/wait_for.h", "#include <chrono>\n"}};
}

std::vector<Violation> checkWith(const std::string& path, const std::string& text) {
  auto tree = baseTree();
  tree[path] = text;
  return check(parseRules(kTable), tree);
}

}  // namespace

TEST_CASE("the base tree keeps the table", "[unit]") {
  CHECK(check(parseRules(kTable), baseTree()).empty());
}

TEST_CASE("the table's rows are read with their folders, ours and categories", "[unit]") {
  const auto rules = parseRules(kTable);
  REQUIRE(rules.size() == 10);
  CHECK(rules[0].folders == std::vector<std::string>{"kernel/include/"});
  CHECK(rules[0].ours.empty());
  CHECK(rules[0].outside == std::set<std::string>{"c", "c++"});
  CHECK(rules[2].folders == std::vector<std::string>{"meta/", "components/"});
  CHECK(rules[3].ours == std::vector<std::string>{"kernel/include/", "tiny/include/tiny_tuple.h"});
  CHECK(rules[1].line == 7);
}

TEST_CASE("a broken table is an error naming its line", "[unit]") {
  CHECK_THROWS_WITH(parseRules("no table here"), Contains("no layering table"));
  CHECK_THROWS_WITH(
      parseRules("<!-- layering:begin -->\n| a | b | c |\n|---|---|---|\n| `kernel/` | — |\n"
                 "<!-- layering:end -->"),
      Contains("line 4") && Contains("three cells"));
  CHECK_THROWS_WITH(
      parseRules("<!-- layering:begin -->\n| a | b | c |\n|---|---|---|\n| `kernel/` | — | Qt |\n"
                 "<!-- layering:end -->"),
      Contains("unknown category 'Qt'"));
  CHECK_THROWS_WITH(
      parseRules("<!-- layering:begin -->\n| a | b | c |\n|---|---|---|\n| `kernel` | — | C |\n"
                 "<!-- layering:end -->"),
      Contains("must end with '/'"));
}

TEST_CASE("include lines are found however spaced, and computed ones are skipped", "[unit]") {
  const auto found = includesOf(
      "#include \"a.h\"\n  #  include <b/c.hpp>\n// #include \"not.h\"\n#include MACRO\n"
      "#include \"d.h\" /* why */\n");
  REQUIRE(found.size() == 3);
  CHECK(found[0].name == "a.h");
  CHECK_FALSE(found[0].angled);
  CHECK(found[1].name == "b/c.hpp");
  CHECK(found[1].angled);
  CHECK(found[1].line == 2);
  CHECK(found[2].name == "d.h");
}

TEST_CASE("outside headers fall into their library's category", "[unit]") {
  CHECK(categoryOf({"stdint.h", true}) == "c");
  CHECK(categoryOf({"vector", true}) == "c++");
  CHECK(categoryOf({"cstdint", true}) == "c++");
  CHECK(categoryOf({"sys/socket.h", true}) == "system");
  CHECK(categoryOf({"boost/asio/io_context.hpp", true}) == "boost");
  CHECK(categoryOf({"yaml-cpp/yaml.h", true}) == "yaml-cpp");
  CHECK(categoryOf({"sqlite3.h", true}) == "sqlite");
  CHECK(categoryOf({"catch2/catch.hpp", true}) == "catch2");
  CHECK(categoryOf({"avr/io.h", true}) == "avr-libc");
  CHECK(categoryOf({"sim_avr.h", true}) == "simavr");
  CHECK(categoryOf({"dds/dds.h", true}) == "cyclonedds");
  CHECK(categoryOf({"zmq.h", true}) == "zeromq");
  CHECK(categoryOf({"sodium.h", true}) == "libsodium");
  CHECK(categoryOf({"gcrypt.h", true}) == "libgcrypt");
  CHECK(categoryOf({"intel-ipsec-mb.h", true}) == "ipsec-mb");
}

TEST_CASE("a folder may use its own files, the folders of its row and its categories", "[unit]") {
  CHECK(checkWith("meta/planner.cpp",
                  "#include <peis/kernel.h>\n#include \"peis/component.h\"\n#include <map>\n"
                  "#include \"planner.h\"\n#include <unistd.h>\n")
            .empty());
  CHECK(checkWith("kernel/src/kernel.cpp", "#include \"log.h\"\n#include <boost/asio.hpp>\n")
            .empty());
  CHECK(checkWith("tests/kernel/space_test.cpp",
                  "#include \"tuple_space.h\"\n#include \"support/wait_for.h\"\n"
                  "#include <catch2/catch.hpp>\n")
            .empty());
  CHECK(checkWith("bridge/src/bridge.cpp", "#include \"tiny_tuple.h\"\n").empty());
}

TEST_CASE("meta/ and components/ cannot reach into kernel internals", "[unit]") {
  for (const auto* path : {"meta/monitor.cpp", "components/sim/world.cpp"}) {
    const auto quoted = checkWith(path, "#include <string>\n#include \"tuple_space.h\"\n");
    REQUIRE(quoted.size() == 1);
    CHECK(quoted[0].line == 2);
    CHECK_THAT(quoted[0].message, Contains("kernel/src/tuple_space.h"));
    CHECK(checkWith(path, "#include \"../../kernel/src/log.h\"\n").size() == 1);
  }
}

TEST_CASE("a name that several files share must be allowed for each of them", "[unit]") {
  auto tree = baseTree();
  tree["kernel/include/peis/log.h"] = "";
  tree["bridge/src/bridge.cpp"] = "#include \"log.h\"\n";
  const auto v = check(parseRules(kTable), tree);
  REQUIRE(v.size() == 1);
  CHECK_THAT(v[0].message, Contains("kernel/src/log.h"));
  // With a log.h of the bridge's own, that one is meant, beside the file
  // or not.
  tree["bridge/src/log.h"] = "";
  tree["bridge/src/util/x.cpp"] = "#include \"log.h\"\n";
  CHECK(check(parseRules(kTable), tree).empty());
}

TEST_CASE("a row's single files do not open their folder", "[unit]") {
  const auto v = checkWith("bridge/src/bridge.cpp", "#include \"tiny_kernel.h\"\n");
  REQUIRE(v.size() == 1);
  CHECK_THAT(v[0].message, Contains("tiny/include/tiny_kernel.h"));
}

TEST_CASE("outside libraries are checked too", "[unit]") {
  // The kernel's public headers use the standard library only.
  const auto boost = checkWith("kernel/include/peis/net.h", "#include <boost/asio.hpp>\n");
  REQUIRE(boost.size() == 1);
  CHECK_THAT(boost[0].message, Contains("is boost"));
  // The tiny kernel: the C standard library only.
  CHECK(checkWith("tiny/src/tiny_kernel.c", "#include <string.h>\n").empty());
  CHECK(checkWith("tiny/src/tiny_kernel.c", "#include <pthread.h>\n").size() == 1);
  CHECK(checkWith("tiny/src/tiny_kernel.c", "#include <vector>\n").size() == 1);
}

TEST_CASE("only the benchmark peers may use Cyclone DDS and ZeroMQ", "[unit]") {
  CHECK(checkWith("bench/peers/dds_peer.cpp", "#include <dds/dds.h>\n").empty());
  CHECK(checkWith("bench/peers/zmq_peer.cpp", "#include <zmq.h>\n").empty());
  CHECK(checkWith("kernel/src/link.cpp", "#include <zmq.h>\n").size() == 1);
  CHECK(checkWith("components/sim/world.cpp", "#include <dds/dds.h>\n").size() == 1);
}

TEST_CASE("a file under no row is reported: a new folder needs a row", "[unit]") {
  const auto v = checkWith("scenarios/runner.cpp", "#include <string>\n");
  REQUIRE(v.size() == 1);
  CHECK(v[0].file == "scenarios/runner.cpp");
  CHECK_THAT(v[0].message, Contains("no row"));
}

TEST_CASE("the longest folder decides: tests/kernel/ may, tests/ may not", "[unit]") {
  CHECK(checkWith("tests/kernel/x_test.cpp", "#include \"tuple_space.h\"\n").empty());
  CHECK(checkWith("tests/other/x_test.cpp", "#include \"tuple_space.h\"\n").size() == 1);
}

TEST_CASE("an angled include is ours only from a public include folder", "[unit]") {
  auto tree = baseTree();
  tree["tiny/ports/avr/avr_uart.h"] = "";
  // simavr's own <avr_uart.h> is not our port's header of the same name.
  CHECK(resolve(tree, "tools/sim.c", {"avr_uart.h", true}).empty());
  CHECK(resolve(tree, "tiny/ports/avr/main.c", {"avr_uart.h", false}) ==
        std::vector<std::string>{"tiny/ports/avr/avr_uart.h"});
  CHECK(resolve(tree, "meta/x.cpp", {"peis/kernel.h", true}) ==
        std::vector<std::string>{"kernel/include/peis/kernel.h"});
  // A standard header is never ours, even if a port ships its own copy.
  tree["tiny/ports/msp430/libc/string.h"] = "";
  CHECK(resolve(tree, "tiny/src/x.c", {"string.h", true}).empty());
}
