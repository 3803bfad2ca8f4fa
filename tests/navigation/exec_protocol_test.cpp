// The ExecGoal / ExecStatus texts: parsing, canonical forms and bad input.
#include "execution/exec_protocol.h"

#include <catch2/catch.hpp>

using namespace peis::exec;

TEST_CASE("actions parse into a name and arguments, with a canonical text", "[unit]") {
  auto a = parseAction("  GoTo( 1.5 ,2 ) ");
  REQUIRE(a);
  CHECK(a->name == "GoTo");
  CHECK(a->args == std::vector<std::string>{"1.5", "2"});
  CHECK(a->toString() == "GoTo(1.5, 2)");
  CHECK(parseAction("Stop")->toString() == "Stop");
  CHECK(parseAction("Stop()")->toString() == "Stop");
  CHECK(parseAction("Talk(wakeup)")->args.at(0) == "wakeup");
}

TEST_CASE("malformed actions are refused with a reason", "[unit]") {
  std::string why;
  CHECK_FALSE(parseAction("", &why));
  CHECK(why == "empty action");
  CHECK_FALSE(parseAction("GoTo(bed", &why));
  CHECK(why.find("expected ')'") != std::string::npos);
  CHECK_FALSE(parseAction("GoTo(a,,b)", &why));
  CHECK(why.find("bad argument ''") != std::string::npos);
  CHECK_FALSE(parseAction("Go To(bed)", &why));
  CHECK_FALSE(parseAction("(bed)", &why));
  CHECK_FALSE(parseAction("9Lives", &why));
  CHECK_FALSE(parseAction("GoTo(be d)", &why));
  CHECK_FALSE(parseAction(std::string(300, 'a'), &why));
  CHECK(why.find("longer than 200") != std::string::npos);
  CHECK_FALSE(parseAction(std::string("GoTo(\x01)"), &why));
}

TEST_CASE("ExecStatus round-trips, with and without a cause", "[unit]") {
  const ExecStatus failed{ExecState::Failed, 12, "GoTo(attic)", "unknown place 'attic'"};
  CHECK(failed.toString() == "failed 12 GoTo(attic) unknown place 'attic'");
  CHECK(parseExecStatus(failed.toString()) == failed);
  const ExecStatus running{ExecState::Running, 3, "GoTo(1.5, 2)", ""};
  CHECK(parseExecStatus(running.toString()) == running);
  const ExecStatus stop{ExecState::Success, 4, "Stop", ""};
  CHECK(parseExecStatus("success 4 Stop") == stop);
  CHECK(parseExecStatus("failed 5 Stop no robot")->cause == "no robot");
  std::string why;
  CHECK_FALSE(parseExecStatus("done 1 GoTo(bed)", &why));
  CHECK_FALSE(parseExecStatus("running x GoTo(bed)", &why));
  CHECK_FALSE(parseExecStatus("running 1", &why));
  CHECK_FALSE(parseExecStatus("running 1 GoTo(bed", &why));
}

TEST_CASE("numbers are whole finite numbers", "[unit]") {
  CHECK(parseNumber("1.5") == 1.5);
  CHECK(parseNumber(" -2 ") == -2.0);
  CHECK_FALSE(parseNumber("1.5m"));
  CHECK_FALSE(parseNumber("nan"));
  CHECK_FALSE(parseNumber("inf"));
  CHECK_FALSE(parseNumber(""));
}
