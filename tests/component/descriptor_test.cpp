// Unit tests of functionality descriptors (peis/descriptor.h).
#include "peis/descriptor.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <string>

#include "peis/error.h"

using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using peis::Descriptor;
using peis::ErrorCode;
using peis::Port;

namespace {

const char* const kCamera = R"(component: camera
functionalities:
  - name: capture
    description: Takes a picture of what is in front of the robot
    inputs: []
    outputs:
      - {name: image, type: image/jpeg}
      - {name: stamp, type: time}
    preconditions:
      - powered
      - lens-open
    cost: 2.5
  - name: track
    inputs:
      - name: target
        type: goal2d
    outputs:
      - name: position
        type: pose2d
    cost: 0
  - name: idle
)";

// Parses `text`, which must fail with InvalidConfig; returns the message.
std::string failure(const std::string& text, const std::string& origin = "camera.yaml") {
  try {
    Descriptor::fromYaml(text, origin);
  } catch (const peis::Error& e) {
    CHECK(e.code() == ErrorCode::InvalidConfig);
    return e.what();
  }
  FAIL("expected a peis::Error for:\n" << text);
  return {};
}

// A file in the temp directory, removed when the test ends.
struct TempFile {
  std::filesystem::path path;
  explicit TempFile(const std::string& text) {
    path = std::filesystem::temp_directory_path() /
           ("peis_descriptor_test_" + std::to_string(::getpid()) + ".yaml");
    std::ofstream(path) << text;
  }
  ~TempFile() {
    std::error_code ignored;
    std::filesystem::remove(path, ignored);
  }
};

}  // namespace

TEST_CASE("fromYaml reads a full descriptor", "[unit][descriptor]") {
  const auto d = Descriptor::fromYaml(kCamera, "camera.yaml");
  CHECK(d.component == "camera");
  REQUIRE(d.functionalities.size() == 3);

  const auto& capture = d.functionalities[0];
  CHECK(capture.name == "capture");
  CHECK(capture.description == "Takes a picture of what is in front of the robot");
  CHECK(capture.inputs.empty());
  CHECK(capture.outputs == std::vector<Port>{{"image", "image/jpeg"}, {"stamp", "time"}});
  CHECK(capture.preconditions == std::vector<std::string>{"powered", "lens-open"});
  CHECK(capture.cost == 2.5);

  const auto& track = d.functionalities[1];
  CHECK(track.name == "track");
  CHECK(track.description.empty());
  CHECK(track.inputs == std::vector<Port>{{"target", "goal2d"}});
  CHECK(track.outputs == std::vector<Port>{{"position", "pose2d"}});
  CHECK(track.preconditions.empty());
  CHECK(track.cost == 0.0);

  // Every field but the name is optional; cost defaults to 1.
  const auto& idle = d.functionalities[2];
  CHECK(idle.name == "idle");
  CHECK(idle.inputs.empty());
  CHECK(idle.outputs.empty());
  CHECK(idle.preconditions.empty());
  CHECK(idle.cost == 1.0);
}

TEST_CASE("a descriptor may have no functionalities", "[unit][descriptor]") {
  const auto d = Descriptor::fromYaml("component: blank\n");
  CHECK(d.component == "blank");
  CHECK(d.functionalities.empty());
  CHECK(Descriptor::fromYaml("component: blank\nfunctionalities: []\n").functionalities.empty());
}

TEST_CASE("toYaml round-trips through fromYaml", "[unit][descriptor]") {
  SECTION("the sample descriptor") {
    const auto d = Descriptor::fromYaml(kCamera);
    const auto again = Descriptor::fromYaml(d.toYaml(), "<round trip>");
    CHECK(again.component == d.component);
    CHECK(again.functionalities == d.functionalities);
  }
  SECTION("a descriptor built in code, with awkward text") {
    Descriptor d;
    d.component = "planner";
    peis::Functionality f;
    f.name = "plan";
    f.description = "Plans: a path, from 'here' to \"there\" # not a comment";
    f.inputs = {{"goal", "pose2d"}, {"map", "grid/occupancy"}};
    f.outputs = {{"path", "path2d"}};
    f.preconditions = {"map-loaded", "localized(yes)"};
    f.cost = 0.1;
    d.functionalities.push_back(f);
    peis::Functionality g;
    g.name = "noop";
    g.cost = 1e6;
    d.functionalities.push_back(g);

    const auto yaml = d.toYaml();
    INFO(yaml);
    const auto again = Descriptor::fromYaml(yaml);
    CHECK(again.component == "planner");
    CHECK(again.functionalities == d.functionalities);
  }
  SECTION("an empty descriptor") {
    Descriptor d;
    d.component = "empty";
    const auto again = Descriptor::fromYaml(d.toYaml());
    CHECK(again.component == "empty");
    CHECK(again.functionalities.empty());
  }
}

TEST_CASE("broken YAML is reported with origin and line", "[unit][descriptor]") {
  const auto message = failure("component: [unclosed", "cam.yaml");
  CHECK_THAT(message, StartsWith("cam.yaml:1:"));
  CHECK_THAT(failure("component: a\nfunctionalities:\n  - name: x\n   bad: [\n", "f.yaml"),
             StartsWith("f.yaml:"));
}

TEST_CASE("an empty document or a non-mapping top level is rejected", "[unit][descriptor]") {
  CHECK_THAT(failure("", "empty.yaml"), StartsWith("empty.yaml") && Contains("mapping"));
  CHECK_THAT(failure("# only a comment\n", "c.yaml"), StartsWith("c.yaml") && Contains("mapping"));
  CHECK_THAT(failure("- component: a\n- component: b\n", "list.yaml"),
             StartsWith("list.yaml:1:") && Contains("mapping"));
  CHECK_THAT(failure("just text\n", "s.yaml"), StartsWith("s.yaml") && Contains("mapping"));
}

TEST_CASE("unknown keys are rejected with their line", "[unit][descriptor]") {
  CHECK_THAT(failure("component: a\ncolour: red\n"),
             StartsWith("camera.yaml:2:") && Contains("'colour'") && Contains("component"));
  CHECK_THAT(failure("component: a\nfunctionalities:\n  - name: f\n    price: 3\n"),
             StartsWith("camera.yaml:4:") && Contains("'price'") && Contains("functionality"));
  CHECK_THAT(failure("component: a\nfunctionalities:\n  - name: f\n    inputs:\n"
                     "      - {name: x, type: t, unit: m}\n"),
             StartsWith("camera.yaml:5:") && Contains("'unit'"));
}

TEST_CASE("the component is required and must be one key part", "[unit][descriptor]") {
  CHECK_THAT(failure("functionalities: []\n", "nocomp.yaml"),
             StartsWith("nocomp.yaml:1:") && Contains("component is missing"));
  // A missing key is named with the line of the mapping that lacks it.
  CHECK_THAT(failure("# a comment\n\nfunctionalities: []\n", "nocomp.yaml"),
             StartsWith("nocomp.yaml:3:") && Contains("component is missing"));
  CHECK_THAT(failure("component: a.b\n"), StartsWith("camera.yaml:1:") && Contains("'a.b'"));
  CHECK_THAT(failure("component: [a, b]\n"), StartsWith("camera.yaml:1:") && Contains("component"));
  CHECK_THAT(failure("component: two words\n"), Contains("component"));
}

TEST_CASE("functionality names must be single key parts", "[unit][descriptor]") {
  CHECK_THAT(failure("component: a\nfunctionalities:\n  - name: capture.fast\n"),
             StartsWith("camera.yaml:3:") && Contains("'capture.fast'"));
  CHECK_THAT(failure("component: a\nfunctionalities:\n  - name: \"x*\"\n"), Contains("'x*'"));
  CHECK_THAT(failure("component: a\nfunctionalities:\n  - description: nameless\n"),
             StartsWith("camera.yaml:3:") && Contains("functionality name is missing"));
}

TEST_CASE("a functionality may be declared only once", "[unit][descriptor]") {
  const auto message = failure(
      "component: a\nfunctionalities:\n  - name: f\n  - name: g\n  - name: f\n    cost: 2\n");
  CHECK_THAT(message, StartsWith("camera.yaml:5:") && Contains("'f'") && Contains("twice"));
}

TEST_CASE("cost must be a finite number >= 0", "[unit][descriptor]") {
  const std::string head = "component: a\nfunctionalities:\n  - name: f\n    cost: ";
  CHECK_THAT(failure(head + "-1\n"), StartsWith("camera.yaml:4:") && Contains("cost"));
  CHECK_THAT(failure(head + "-0.001\n"), Contains("cost"));
  CHECK_THAT(failure(head + "cheap\n"), StartsWith("camera.yaml:4:") && Contains("number"));
  CHECK_THAT(failure(head + ".inf\n"), Contains("cost"));
  CHECK_THAT(failure(head + ".nan\n"), Contains("cost"));
  CHECK_THAT(failure(head + "[1]\n"), Contains("cost"));
  CHECK(Descriptor::fromYaml(head + "0\n").functionalities[0].cost == 0.0);
  CHECK(Descriptor::fromYaml(head + "1e3\n").functionalities[0].cost == 1000.0);
}

TEST_CASE("inputs, outputs, preconditions and functionalities must be lists",
          "[unit][descriptor]") {
  const std::string head = "component: a\nfunctionalities:\n  - name: f\n";
  CHECK_THAT(failure(head + "    inputs: image\n"),
             StartsWith("camera.yaml:4:") && Contains("inputs must be a list"));
  CHECK_THAT(failure(head + "    outputs: {name: x, type: y}\n"),
             StartsWith("camera.yaml:4:") && Contains("outputs must be a list"));
  CHECK_THAT(failure(head + "    preconditions: powered\n"),
             StartsWith("camera.yaml:4:") && Contains("preconditions must be a list"));
  CHECK_THAT(failure("component: a\nfunctionalities:\n  name: f\n"),
             StartsWith("camera.yaml:3:") && Contains("functionalities must be a list"));
  CHECK_THAT(failure(head + "    preconditions: [[a]]\n"), Contains("precondition"));
  CHECK_THAT(failure(head + "    inputs: [x]\n"), Contains("mapping"));
}

TEST_CASE("ports need a key-part name and a one-word type", "[unit][descriptor]") {
  const std::string head = "component: a\nfunctionalities:\n  - name: f\n    inputs:\n";
  CHECK_THAT(failure(head + "      - {name: x, type: pose 2d}\n"),
             StartsWith("camera.yaml:5:") && Contains("type") && Contains("not a term"));
  CHECK_THAT(failure(head + "      - {name: x, type: \"\"}\n"), Contains("not a term"));
  CHECK_THAT(failure(head + "      - {name: a.b, type: t}\n"),
             StartsWith("camera.yaml:5:") && Contains("'a.b'"));
  CHECK_THAT(failure(head + "      - {name: x}\n"),
             StartsWith("camera.yaml:5:") && Contains("inputs type is missing"));
  CHECK_THAT(failure(head + "      - {type: t}\n"),
             StartsWith("camera.yaml:5:") && Contains("inputs name is missing"));
}

TEST_CASE("fromFile reads a file and names it in errors", "[unit][descriptor]") {
  SECTION("a good file") {
    TempFile file(kCamera);
    const auto d = Descriptor::fromFile(file.path.string());
    CHECK(d.component == "camera");
    CHECK(d.functionalities.size() == 3);
  }
  SECTION("a broken file") {
    TempFile file("component: a\nbogus: 1\n");
    try {
      Descriptor::fromFile(file.path.string());
      FAIL("no exception");
    } catch (const peis::Error& e) {
      CHECK(e.code() == ErrorCode::InvalidConfig);
      CHECK_THAT(e.what(), StartsWith(file.path.string() + ":2:") && Contains("'bogus'"));
    }
  }
  SECTION("a missing file") {
    const std::string path = "/nonexistent/peis/descriptor.yaml";
    try {
      Descriptor::fromFile(path);
      FAIL("no exception");
    } catch (const peis::Error& e) {
      CHECK(e.code() == ErrorCode::InvalidConfig);
      CHECK_THAT(e.what(), Contains(path) && Contains("cannot open"));
    }
  }
}

TEST_CASE("formatPorts writes name:type pairs separated by spaces", "[unit][descriptor]") {
  CHECK(peis::formatPorts({}) == "");
  CHECK(peis::formatPorts({{"image", "image/jpeg"}}) == "image:image/jpeg");
  CHECK(peis::formatPorts({{"goal", "pose2d"}, {"map", "grid"}, {"speed", "double"}}) ==
        "goal:pose2d map:grid speed:double");
}

// The planner's schema (docs/configuration.md): typed terms with variables,
// keys, activation, preconditions over facts.
const char* const kTracker = R"yaml(component: tracker
functionalities:
  - name: track
    inputs:
      - {name: left, type: "image( ?a )"}
      - {name: right, type: "image(?b)", key: "mi-cam.?b"}
    outputs:
      - {name: position, type: "position(?robot)"}
      - {name: seen, type: "activity(?robot, kitchen)", key: "seen.?robot"}
    preconditions: ["in-view(?robot, ?a)", "in-view(?robot,?b)", "?a != ?b"]
    activation: tracking
    cost: 2
)yaml";

TEST_CASE("typed ports, keys, activation and preconditions", "[unit][descriptor]") {
  const auto d = Descriptor::fromYaml(kTracker, "tracker.yaml");
  const auto& f = d.functionalities.at(0);
  CHECK(f.inputs[0].type == "image(?a)");  // canonical form
  CHECK(f.inputs[0].inputKey() == "mi-left.?a");
  CHECK(f.inputs[1].inputKey() == "mi-cam.?b");
  CHECK(f.outputs[0].outputKey() == "position.?robot");
  CHECK(f.outputs[1].type == "activity(?robot,kitchen)");
  CHECK(f.outputs[1].outputKey() == "seen.?robot");
  CHECK(f.preconditions ==
        std::vector<std::string>{"in-view(?robot,?a)", "in-view(?robot,?b)", "?a != ?b"});
  CHECK(f.activation == "tracking");
  CHECK(peis::formatPorts(f.inputs) == "left:image(?a) right:image(?b)@mi-cam.?b");
  const auto again = Descriptor::fromYaml(d.toYaml(), "<round trip>");
  CHECK(again == d);
  // ?self is the PEIS's own name: no key suffix for it.
  CHECK(Port{"position", "position(?self)", ""}.inputKey() == "mi-position");
}

TEST_CASE("terms parse to a canonical form or say why not", "[unit][descriptor]") {
  CHECK(peis::Term::parse(" activity( ?p , kitchen ) ")->toString() == "activity(?p,kitchen)");
  CHECK(peis::Term::parse("image/jpeg")->args.empty());
  CHECK(peis::Term::parse("f(?x, a, ?x)")->variables() == std::vector<std::string>{"?x"});
  CHECK_FALSE(peis::Term::parse("f(a, b)")->isGround() == false);
  std::string why;
  CHECK_FALSE(peis::Term::parse("f(a", &why));
  CHECK_THAT(why, Contains("quote"));
  CHECK_FALSE(peis::Term::parse("f()", &why));
  CHECK_FALSE(peis::Term::parse("f(a.b)", &why));
  CHECK_FALSE(peis::Term::parse("f(?)", &why));
  CHECK_FALSE(peis::Term::parse("", &why));
}

TEST_CASE("bad typed descriptors are errors with file:line", "[unit][descriptor]") {
  const std::string head = "component: a\nfunctionalities:\n  - name: f\n";
  CHECK_THAT(failure(head + "    outputs: [{name: x, type: \"x(?a\"}]\n"),
             StartsWith("camera.yaml:4:") && Contains("not a term"));
  CHECK_THAT(failure(head + "    inputs: [{name: x, type: t, key: x-in}]\n"),
             StartsWith("camera.yaml:4:") && Contains("must start with 'mi-'"));
  CHECK_THAT(failure(head + "    outputs: [{name: x, type: t, key: \"a..b\"}]\n"),
             StartsWith("camera.yaml:4:") && Contains("not a valid key"));
  CHECK_THAT(failure(head + "    preconditions: [\"bad(\"]\n"),
             StartsWith("camera.yaml:4:") && Contains("precondition"));
  CHECK_THAT(
      failure(head + "    outputs: [{name: x, type: t}]\n    preconditions: [\"?q != a\"]\n"),
      Contains("?q") && Contains("appears in no type"));
  CHECK_THAT(
      failure(head +
              "    outputs: [{name: x, type: \"t(?a)\"}]\n    preconditions: [\"?a != ?a\"]\n"),
      Contains("can never hold"));
  CHECK_THAT(
      failure(head + "    outputs: [{name: x, type: t, key: k}, {name: y, type: u, key: k}]\n"),
      Contains("two outputs to the key 'k'"));
  CHECK_THAT(failure(head + "    activation: \"a b\"\n"),
             StartsWith("camera.yaml:4:") && Contains("actuator"));
}
