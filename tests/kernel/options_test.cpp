// Unit tests of the --peis-* command-line flags (peis/options.h).
#include "peis/options.h"

#include <catch2/catch.hpp>
#include <chrono>
#include <string>
#include <utility>
#include <vector>

#include "peis/error.h"

using Catch::Matchers::Contains;
using peis::ErrorCode;
using peis::Options;

namespace {

// A mutable argv as main() gets it: argc strings and a trailing nullptr.
struct Args {
  std::vector<std::string> storage;
  std::vector<char*> argv;
  int argc = 0;

  explicit Args(std::vector<std::string> args) : storage(std::move(args)) {
    for (auto& s : storage) argv.push_back(s.data());
    argv.push_back(nullptr);
    argc = static_cast<int>(storage.size());
  }
  Options parse() { return Options::fromArgs(argc, argv.data()); }
  // What is left in argv after parsing, checking the nullptr terminator.
  std::vector<std::string> left() const {
    std::vector<std::string> result;
    for (int i = 0; i < argc; ++i) result.emplace_back(argv[i]);
    REQUIRE(argv[argc] == nullptr);
    return result;
  }
};

using Strings = std::vector<std::string>;

// Parses `args` (after a program name) and returns the options.
Options parse(Strings args) {
  args.insert(args.begin(), "prog");
  Args a(std::move(args));
  return a.parse();
}

// Parses `args`, which must fail with InvalidArgument; returns the message.
std::string failure(Strings args) {
  args.insert(args.begin(), "prog");
  Args a(std::move(args));
  try {
    a.parse();
  } catch (const peis::Error& e) {
    CHECK(e.code() == ErrorCode::InvalidArgument);
    return e.what();
  }
  FAIL("expected a peis::Error");
  return {};
}

template <typename Fn>
peis::Error errorOf(Fn&& fn) {
  try {
    fn();
  } catch (const peis::Error& e) {
    return e;
  }
  FAIL("expected a peis::Error");
  return peis::Error(ErrorCode::Stopped, "");
}

}  // namespace

TEST_CASE("defaults without any flag", "[unit][options]") {
  Args a({"/usr/local/bin/robot", "input.txt"});
  const auto o = a.parse();
  CHECK_FALSE(o.id.has_value());
  CHECK(o.name.empty());
  CHECK(o.port == 0);
  CHECK(o.connect.empty());
  CHECK(o.setTuples.empty());
  CHECK(o.ecology == "default");
  CHECK(o.discovery);
  CHECK(o.maxDataBytes == peis::kDefaultMaxDataBytes);
  CHECK_FALSE(o.help);
  CHECK(o.programName == "robot");
  CHECK(a.argc == 2);
  CHECK(a.left() == Strings{"/usr/local/bin/robot", "input.txt"});
}

TEST_CASE("programName is argv[0] without its directory", "[unit][options]") {
  Args plain({"camera"});
  CHECK(plain.parse().programName == "camera");
  Args relative({"./build/bin/camera"});
  CHECK(relative.parse().programName == "camera");
}

TEST_CASE("every flag in the '--flag value' form", "[unit][options]") {
  Args a({"prog", "--peis-id", "42", "--peis-name", "Astrid", "--peis-port", "9000",
          "--peis-connect", "host:8000", "--peis-set-tuple", "a.b=hello", "--peis-ecology", "lab",
          "--peis-no-discovery", "--peis-max-data", "1024"});
  const auto o = a.parse();
  CHECK(o.id == std::optional<peis::PeisId>(42));
  CHECK(o.name == "Astrid");
  CHECK(o.port == 9000);
  CHECK(o.connect == Strings{"host:8000"});
  REQUIRE(o.setTuples.size() == 1);
  CHECK(o.setTuples[0] == std::pair<std::string, std::string>{"a.b", "hello"});
  CHECK(o.ecology == "lab");
  CHECK_FALSE(o.discovery);
  CHECK(o.maxDataBytes == 1024);
  CHECK(a.argc == 1);
  CHECK(a.left() == Strings{"prog"});
}

TEST_CASE("every flag in the '--flag=value' form", "[unit][options]") {
  Args a({"prog", "--peis-id=42", "--peis-name=Astrid", "--peis-port=9000",
          "--peis-connect=host:8000", "--peis-set-tuple=a.b=hello", "--peis-ecology=lab",
          "--peis-no-discovery", "--peis-max-data=1024"});
  const auto o = a.parse();
  CHECK(o.id == std::optional<peis::PeisId>(42));
  CHECK(o.name == "Astrid");
  CHECK(o.port == 9000);
  CHECK(o.connect == Strings{"host:8000"});
  REQUIRE(o.setTuples.size() == 1);
  CHECK(o.setTuples[0] == std::pair<std::string, std::string>{"a.b", "hello"});
  CHECK(o.ecology == "lab");
  CHECK_FALSE(o.discovery);
  CHECK(o.maxDataBytes == 1024);
  CHECK(a.left() == Strings{"prog"});
}

TEST_CASE("flag values at their limits", "[unit][options]") {
  CHECK(parse({"--peis-id", "1"}).id == std::optional<peis::PeisId>(1));
  CHECK(parse({"--peis-id", "2147483647"}).id == std::optional<peis::PeisId>(peis::kMaxPeisId));
  CHECK(parse({"--peis-port", "0"}).port == 0);
  CHECK(parse({"--peis-port", "65535"}).port == 65535);
  CHECK(parse({"--peis-max-data", "0"}).maxDataBytes == 0);
  CHECK(parse({"--peis-max-data", "2147483647"}).maxDataBytes == peis::kMaxDataBytes);
  CHECK(parse({"--peis-ecology", std::string(64, 'e')}).ecology == std::string(64, 'e'));
}

TEST_CASE("Options: --peis-connect and --peis-set-tuple are repeatable", "[unit][options]") {
  const auto o = parse({"--peis-connect", "a:1", "--peis-connect=b:2", "--peis-connect", "[::1]:3",
                        "--peis-set-tuple", "x=1", "--peis-set-tuple=y.z=2", "--peis-set-tuple",
                        "eq=a=b", "--peis-set-tuple", "empty="});
  CHECK(o.connect == Strings{"a:1", "b:2", "[::1]:3"});
  using KV = std::pair<std::string, std::string>;
  CHECK(o.setTuples == std::vector<KV>{{"x", "1"}, {"y.z", "2"}, {"eq", "a=b"}, {"empty", ""}});
}

TEST_CASE("a repeated single-valued flag keeps the last value", "[unit][options]") {
  const auto o = parse({"--peis-id", "1", "--peis-id=2", "--peis-port", "5", "--peis-port", "6"});
  CHECK(o.id == std::optional<peis::PeisId>(2));
  CHECK(o.port == 6);
}

TEST_CASE("other arguments are kept in order and argc is updated", "[unit][options]") {
  Args a({"prog", "-v", "--peis-id", "3", "file1", "--verbose", "--peis-port=77", "file2", "-x",
          "--peis-no-discovery", "last"});
  const auto o = a.parse();
  CHECK(o.id == std::optional<peis::PeisId>(3));
  CHECK(o.port == 77);
  CHECK_FALSE(o.discovery);
  CHECK(a.argc == 7);
  CHECK(a.left() == Strings{"prog", "-v", "file1", "--verbose", "file2", "-x", "last"});
}

TEST_CASE("'--' stops parsing; the rest is left to the program", "[unit][options]") {
  Args a({"prog", "--peis-id", "3", "--", "--peis-id", "4", "--peis-bogus", "--help", "x"});
  const auto o = a.parse();
  CHECK(o.id == std::optional<peis::PeisId>(3));
  CHECK_FALSE(o.help);  // --help after '--' is the program's
  CHECK(a.left() == Strings{"prog", "--", "--peis-id", "4", "--peis-bogus", "--help", "x"});
  CHECK(a.argc == 7);
}

TEST_CASE("Options: --help and -h set help and stay in argv", "[unit][options]") {
  for (const char* flag : {"--help", "-h"}) {
    INFO("flag: " << flag);
    Args a({"prog", "--peis-id", "5", flag, "more"});
    const auto o = a.parse();
    CHECK(o.help);
    CHECK(o.id == std::optional<peis::PeisId>(5));
    CHECK(a.left() == Strings{"prog", flag, "more"});
  }
}

TEST_CASE("unknown --peis-* flags are rejected", "[unit][options]") {
  CHECK_THAT(failure({"--peis-foo"}), Contains("--peis-foo") && Contains("unknown"));
  CHECK_THAT(failure({"--peis-foo=bar"}), Contains("--peis-foo:"));
  CHECK_THAT(failure({"--peis-"}), Contains("--peis-"));
  CHECK_THAT(failure({"--peis-ID", "3"}), Contains("--peis-ID"));
}

TEST_CASE("a flag without its value is rejected", "[unit][options]") {
  for (const char* flag : {"--peis-id", "--peis-name", "--peis-port", "--peis-connect",
                           "--peis-set-tuple", "--peis-ecology", "--peis-max-data"}) {
    INFO("flag: " << flag);
    const auto message = failure({flag});
    CHECK_THAT(message, Contains(flag) && Contains("needs a value"));
  }
  CHECK_THAT(failure({"--peis-no-discovery=yes"}),
             Contains("--peis-no-discovery") && Contains("no value"));
}

TEST_CASE("bad ids are rejected", "[unit][options]") {
  for (const char* value : {"0", "abc", "2147483648", "-1", "+3", "", "1.5"}) {
    INFO("value: '" << value << "'");
    CHECK_THAT(failure({"--peis-id", value}), Contains("--peis-id"));
    CHECK_THAT(failure({std::string("--peis-id=") + value}), Contains("--peis-id"));
  }
  CHECK_THAT(failure({"--peis-id", "abc"}), Contains("'abc'"));
}

TEST_CASE("bad names are rejected", "[unit][options]") {
  for (const char* value : {"123", "a.b", "bad name", "", "a*"}) {
    INFO("value: '" << value << "'");
    CHECK_THAT(failure({"--peis-name", value}), Contains("--peis-name"));
  }
  CHECK_THAT(failure({"--peis-name", std::string(65, 'n')}), Contains("--peis-name"));
}

TEST_CASE("bad ports and data limits are rejected", "[unit][options]") {
  for (const char* value : {"70000", "65536", "-1", "abc", "", "80x"}) {
    INFO("value: '" << value << "'");
    CHECK_THAT(failure({"--peis-port", value}), Contains("--peis-port"));
  }
  CHECK_THAT(failure({"--peis-port=70000"}), Contains("'70000'") && Contains("65535"));
  for (const char* value : {"2147483648", "-5", "1k", "99999999999999999999999"}) {
    INFO("value: '" << value << "'");
    CHECK_THAT(failure({"--peis-max-data", value}), Contains("--peis-max-data"));
  }
}

TEST_CASE("bad --peis-connect targets are rejected", "[unit][options]") {
  for (const char* value :
       {"nohost", "host:0", "host:", ":80", "host:70000", "host:http", "[]:80", ""}) {
    INFO("value: '" << value << "'");
    CHECK_THAT(failure({"--peis-connect", value}), Contains("--peis-connect"));
  }
}

TEST_CASE("bad --peis-set-tuple values are rejected", "[unit][options]") {
  CHECK_THAT(failure({"--peis-set-tuple", "novalue"}),
             Contains("--peis-set-tuple") && Contains("KEY=VALUE"));
  for (const char* value : {"a..b=1", "=1", "a b=1", "a.*=1", ".a=1"}) {
    INFO("value: '" << value << "'");
    CHECK_THAT(failure({"--peis-set-tuple", value}), Contains("--peis-set-tuple"));
  }
  CHECK_THAT(failure({"--peis-set-tuple=a..b=1"}), Contains("part 2 is empty"));
}

TEST_CASE("bad ecology names are rejected", "[unit][options]") {
  CHECK_THAT(failure({"--peis-ecology="}), Contains("--peis-ecology"));
  CHECK_THAT(failure({"--peis-ecology", ""}), Contains("--peis-ecology"));
  CHECK_THAT(failure({"--peis-ecology", "my lab"}), Contains("--peis-ecology"));
  CHECK_THAT(failure({"--peis-ecology", std::string(65, 'e')}), Contains("--peis-ecology"));
  CHECK_THAT(failure({"--peis-ecology", "caf\xc3\xa9"}), Contains("--peis-ecology"));
}

TEST_CASE("parseHostPort splits HOST:PORT", "[unit][options]") {
  using HP = std::pair<std::string, std::uint16_t>;
  CHECK(peis::parseHostPort("localhost:9000") == HP{"localhost", 9000});
  CHECK(peis::parseHostPort("10.0.0.2:1") == HP{"10.0.0.2", 1});
  CHECK(peis::parseHostPort("robot.local:65535") == HP{"robot.local", 65535});
  CHECK(peis::parseHostPort("[::1]:9000") == HP{"::1", 9000});
  CHECK(peis::parseHostPort("[fe80::1%eth0]:80") == HP{"fe80::1%eth0", 80});

  for (const char* text : {"", "nohost", "host:", ":9000", "host:0", "host:65536", "host:-1",
                           "host:12ab", "[]:9000", "[::1]"}) {
    INFO("text: '" << text << "'");
    const auto e = errorOf([&] { peis::parseHostPort(text); });
    CHECK(e.code() == ErrorCode::InvalidArgument);
    CHECK_THAT(e.what(), Contains("--peis-connect"));
  }
}

TEST_CASE("Options::validate checks a struct filled in code", "[unit][options]") {
  Options ok;
  ok.id = 5;
  ok.name = "Astrid";
  ok.connect = {"a:1", "[::1]:2"};
  ok.setTuples = {{"a.b", "1"}};
  ok.ecology = "lab";
  ok.maxDataBytes = peis::kMaxDataBytes;
  CHECK_NOTHROW(ok.validate());
  CHECK_NOTHROW(Options{}.validate());

  struct Case {
    const char* what;
    void (*change)(Options&);
    const char* flag;
  };
  const Case cases[] = {
      {"id 0", [](Options& o) { o.id = 0; }, "--peis-id"},
      {"negative id", [](Options& o) { o.id = -4; }, "--peis-id"},
      {"all-digit name", [](Options& o) { o.name = "12"; }, "--peis-name"},
      {"dotted name", [](Options& o) { o.name = "a.b"; }, "--peis-name"},
      {"connect without port", [](Options& o) { o.connect.push_back("nohost"); }, "--peis-connect"},
      {"set-tuple bad key", [](Options& o) { o.setTuples.emplace_back("a..b", "1"); },
       "--peis-set-tuple"},
      {"empty ecology", [](Options& o) { o.ecology = ""; }, "--peis-ecology"},
      {"data limit", [](Options& o) { o.maxDataBytes = peis::kMaxDataBytes + 1; },
       "--peis-max-data"},
      // Durations a timer or a u32 wire field could not hold (issue 9).
      {"liveness of centuries", [](Options& o) { o.liveness = std::chrono::milliseconds::max(); },
       "--peis-liveness-ms"},
      {"write timeout over u32 ms",
       [](Options& o) { o.writeTimeout = std::chrono::milliseconds(0x100000000LL); },
       "writeTimeout"},
      {"lease over u32 ms", [](Options& o) { o.subscriptionLease = std::chrono::hours(24 * 365); },
       "subscriptionLease"},
  };
  for (const auto& c : cases) {
    INFO("case: " << c.what);
    Options o = ok;
    c.change(o);
    const auto e = errorOf([&] { o.validate(); });
    CHECK(e.code() == ErrorCode::InvalidArgument);
    CHECK_THAT(e.what(), Contains(c.flag));
  }
}

TEST_CASE("helpText mentions every flag", "[unit][options]") {
  const auto text = Options::helpText();
  for (const char* flag :
       {"--peis-id", "--peis-name", "--peis-port", "--peis-connect", "--peis-set-tuple",
        "--peis-ecology", "--peis-no-discovery", "--peis-max-data", "--help", "-h"}) {
    INFO("flag: " << flag);
    CHECK_THAT(text, Contains(flag));
  }
}

TEST_CASE("the limits' flags (docs/security.md)", "[unit][options]") {
  const auto defaults = parse({}).limits;
  CHECK(defaults.handshake == std::chrono::milliseconds(5000));
  CHECK(defaults.maxConnections == 256);
  CHECK(defaults.relayGrace == std::chrono::milliseconds(2000));
  const auto o = parse({"--peis-handshake-ms",
                        "300",
                        "--peis-max-connections",
                        "7",
                        "--peis-max-handshakes-per-host",
                        "3",
                        "--peis-max-routes",
                        "99",
                        "--peis-max-held-bytes=4096",
                        "--peis-quota-keys",
                        "5",
                        "--peis-quota-bytes",
                        "6",
                        "--peis-quota-total-keys",
                        "8",
                        "--peis-quota-total-bytes",
                        "9",
                        "--peis-id-claim-ms",
                        "0",
                        "--peis-relay-grace-ms",
                        "250"})
                     .limits;
  CHECK(o.handshake == std::chrono::milliseconds(300));
  CHECK(o.maxConnections == 7);
  CHECK(o.maxHandshakesPerHost == 3);
  CHECK(o.maxRoutes == 99);
  CHECK(o.maxHeldBytes == 4096);
  CHECK(o.quotaKeys == 5);
  CHECK(o.quotaBytes == 6);
  CHECK(o.quotaTotalKeys == 8);
  CHECK(o.quotaTotalBytes == 9);
  CHECK(o.idClaimWindow == std::chrono::milliseconds(0));
  CHECK(o.relayGrace == std::chrono::milliseconds(250));
  CHECK_THAT(failure({"--peis-handshake-ms", "99"}), Contains("--peis-handshake-ms"));
  CHECK_THAT(failure({"--peis-max-routes", "0"}), Contains("--peis-max-routes"));
  CHECK_THAT(failure({"--peis-relay-grace-ms", "60001"}), Contains("--peis-relay-grace-ms"));
  CHECK_THAT(failure({"--peis-id-claim-ms", "-1"}), Contains("--peis-id-claim-ms"));
}
