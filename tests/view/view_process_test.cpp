// peis-view as a program, against a test ecology of `peis node` processes,
// spoken to directly over HTTP and WebSocket as a browser would: the page
// and its files, the hello, the graph, the live table, edits that reach the
// owner and the owner's error, pictures, and every kind of bad input (not
// JSON, unknown commands, bad patterns, huge edits, foreign hosts and
// origins, a page that stops reading, a page that floods); and the
// meta-level panel against a real peis-configurator deploying a goal.
// Deadlines are generous; nothing asserts a timing.
#include <catch2/catch.hpp>
#include <csignal>
#include <fstream>
#include <regex>
#include <set>

#include "camera/image_tuple.h"
#include "support/integration.h"
#include "support/process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"
#include "view/json.h"
#include "view/view_client.h"

using namespace std::chrono_literals;
using Catch::Matchers::Contains;
using peis::test::awaitNode;
using peis::test::describe;
using peis::test::httpGet;
using peis::test::HttpResult;
using peis::test::kDeadline;
using peis::test::Process;
using peis::test::runCli;
using peis::test::startNode;
using peis::test::uniqueEcology;
using peis::test::ViewSocket;
using peis::test::waitFor;
namespace json = peis::view::json;

namespace {

std::string viewPath() { return PEIS_VIEW_PATH; }

// peis-view in `ecology` on a free port, with extra options.
struct View {
  std::unique_ptr<Process> process;
  std::uint16_t port = 0;

  View(const std::string& ecology, std::vector<std::string> options = {}) {
    std::vector<std::string> argv{viewPath(), "--port", "0", "--peis-ecology", ecology};
    argv.insert(argv.end(), options.begin(), options.end());
    process = std::make_unique<Process>(argv);
    static const std::regex line(R"(peis view: http://127\.0\.0\.1:(\d+)/)");
    std::smatch match;
    std::string out;
    waitFor(
        [&] {
          out = process->out();
          return std::regex_search(out, match, line) || !process->running();
        },
        kDeadline);
    INFO(process->describe());
    REQUIRE(std::regex_search(out, match, line));
    port = static_cast<std::uint16_t>(std::stoul(match[1]));
  }
};

json::Value parse(const std::string& text) {
  INFO(text.substr(0, 2000));
  return json::parse(text);
}

std::string typeOf(const json::Value& message) {
  const auto* type = message.member("type");
  return type && type->asString() ? *type->asString() : "";
}

const json::Array& arrayOf(const json::Value* value) {
  static const json::Array empty;
  if (!value) return empty;
  const auto* array = std::get_if<json::Array>(&value->v);
  return array ? *array : empty;
}

std::string stringOf(const json::Value* value) {
  return value && value->asString() ? *value->asString() : "";
}

double numberOf(const json::Value* value) {
  return value && value->asNumber() ? *value->asNumber() : -1;
}

// A page as the browser's script keeps it: every message of the view
// applied, so a test waits for a state, whichever message brought it.
class Page {
 public:
  explicit Page(std::uint16_t port, const std::string& origin = "", int receiveBuffer = 0)
      : socket(port, origin, receiveBuffer) {}

  ViewSocket socket;
  std::optional<json::Value> hello;
  std::map<std::string, json::Value> rows;  // the table: id -> row
  std::string filter;                       // the table's filter
  std::optional<json::Value> graph;
  std::map<std::string, json::Value> metaRows;  // the meta-level panel: id -> row
  std::vector<json::Value> log;                 // the meta-level's changes, in order
  std::vector<json::Value> replies, errors;
  // Called with every update (for counting).
  std::function<void(const json::Value&)> onUpdate;

  void apply(const json::Value& m) {
    const std::string type = typeOf(m);
    if (type == "hello") hello = m;
    if (type == "reply") replies.push_back(m);
    if (type == "error") errors.push_back(m);
    if (type != "update") return;
    if (onUpdate) onUpdate(m);
    if (const auto* table = m.member("table")) {
      if (*table->member("reset")->asBool()) {
        rows.clear();
        filter = stringOf(table->member("filter"));
      }
      for (const auto& row : arrayOf(table->member("rows"))) rows[stringOf(row.member("id"))] = row;
      for (const auto& id : arrayOf(table->member("deleted"))) rows.erase(stringOf(&id));
    }
    if (const auto* g = m.member("graph")) graph = *g;
    if (const auto* meta = m.member("meta")) {
      if (*meta->member("reset")->asBool()) metaRows.clear();
      for (const auto& row : arrayOf(meta->member("rows")))
        metaRows[stringOf(row.member("id"))] = row;
      for (const auto& id : arrayOf(meta->member("deleted"))) metaRows.erase(stringOf(&id));
    }
    if (const auto* l = m.member("log")) {
      if (*l->member("reset")->asBool()) log.clear();
      for (const auto& entry : arrayOf(l->member("entries"))) log.push_back(entry);
    }
  }

  std::string metaValue(long owner, const std::string& key) const {
    auto it = metaRows.find(std::to_string(owner) + "." + key);
    return it == metaRows.end() ? "<absent>" : stringOf(it->second.member("value"));
  }
  // The id of the PEIS of that name in the graph, or 0.
  long idOf(const std::string& name) const {
    if (graph)
      for (const auto& node : arrayOf(graph->member("nodes")))
        if (stringOf(node.member("name")) == name)
          return static_cast<long>(numberOf(node.member("id")));
    return 0;
  }

  // Reads and applies messages until `condition` holds; fails at the deadline.
  void waitUntil(const std::function<bool()>& condition, const std::string& what,
                 std::chrono::milliseconds deadline = kDeadline) {
    const auto until = std::chrono::steady_clock::now() + deadline;
    std::string last;
    while (!condition()) {
      const auto now = std::chrono::steady_clock::now();
      if (now >= until || socket.closed()) {
        INFO("waiting for " << what << "; closed: " << socket.closed()
                            << "; last message: " << last.substr(0, 2000));
        FAIL("not in time");
      }
      auto text = socket.next(std::chrono::duration_cast<std::chrono::milliseconds>(until - now));
      if (!text) continue;
      last = *text;
      apply(parse(*text));
    }
  }

  std::string value(const std::string& id) const {
    auto it = rows.find(id);
    return it == rows.end() ? "<absent>" : stringOf(it->second.member("value"));
  }
  std::set<long> peis() const {
    std::set<long> ids;
    if (graph)
      for (const auto& node : arrayOf(graph->member("nodes")))
        ids.insert(static_cast<long>(numberOf(node.member("id"))));
    return ids;
  }
  // The reply to `request`, once it came.
  json::Value reply(double request) {
    auto find = [&]() -> const json::Value* {
      for (const auto& r : replies)
        if (numberOf(r.member("request")) == request) return &r;
      return nullptr;
    };
    waitUntil([&] { return find() != nullptr; }, "the reply to request " + std::to_string(request));
    return *find();
  }
  // The next error message, once it came.
  json::Value nextError() {
    const std::size_t seen = errors.size();
    waitUntil([&] { return errors.size() > seen; }, "an error message");
    return errors[seen];
  }
};

std::string setCommand(int request, const std::string& tuple, const std::string& value) {
  json::Writer w;
  w.beginObject().key("op").string("set").key("request").integer(request);
  w.key("tuple").string(tuple).key("value").string(value).endObject();
  return w.take();
}

json::Value stats(std::uint16_t port) {
  const auto result = httpGet(port, "/stats");
  REQUIRE(result.status == 200);
  return parse(result.body);
}

double statOf(std::uint16_t port, const char* name) { return numberOf(stats(port).member(name)); }

}  // namespace

TEST_CASE("peis-view serves its page, lists the ecology and shows a change live", "[integration]") {
  const auto ecology = uniqueEcology("view-live");
  auto sensor = startNode(ecology, {"--peis-name", "sensor", "--peis-set-tuple", "brightness=40"});
  auto lamp = startNode(ecology, {"--peis-name", "lamp", "--peis-set-tuple", "light=off"});
  const auto s = awaitNode(*sensor);
  const auto l = awaitNode(*lamp);
  REQUIRE(runCli(ecology, {"meta", "lamp.mi-brightness", "sensor.brightness"}).status == 0);
  View view(ecology);

  const auto page = httpGet(view.port, "/");
  CHECK(page.status == 200);
  CHECK_THAT(page.contentType, Contains("text/html"));
  CHECK_THAT(page.body, Contains("<title>PEIS view</title>"));
  CHECK_THAT(page.body, Contains("/view.js"));
  CHECK(httpGet(view.port, "/view.js").status == 200);
  CHECK(httpGet(view.port, "/view.css").status == 200);
  const auto missing = httpGet(view.port, "/nothing");
  CHECK(missing.status == 404);
  CHECK_THAT(missing.body, Contains("not found: /nothing"));
  // DNS rebinding: a request naming another host is refused.
  const auto foreign = httpGet(view.port, "/", "evil.example:80");
  CHECK(foreign.status == 403);
  CHECK_THAT(foreign.body, Contains("answers only to localhost"));

  Page browser(view.port);
  browser.waitUntil([&] { return browser.hello.has_value(); }, "hello");
  CHECK(stringOf(browser.hello->member("ecology")) == ecology);
  CHECK(stringOf(browser.hello->member("filter")) == "*.**");

  // The graph lists both PEIS, a link between them, and the meta link.
  auto metaLink = [&] {
    if (!browser.graph) return false;
    for (const auto& c : arrayOf(browser.graph->member("configuration")))
      if (numberOf(c.member("consumer")) == l.id && numberOf(c.member("producer")) == s.id &&
          stringOf(c.member("producerKey")) == "brightness")
        return true;
    return false;
  };
  browser.waitUntil([&] { return browser.peis().count(s.id) && browser.peis().count(l.id); },
                    "both PEIS in the graph");
  browser.waitUntil(metaLink, "lamp.mi-brightness <- sensor.brightness in the graph");
  browser.waitUntil([&] { return !arrayOf(browser.graph->member("links")).empty(); }, "a link");

  const std::string brightness = std::to_string(s.id) + ".brightness";
  browser.waitUntil([&] { return browser.value(brightness) == "40"; }, "sensor.brightness = 40");
  REQUIRE(runCli(ecology, {"set", "sensor.brightness", "17"}).status == 0);
  browser.waitUntil([&] { return browser.value(brightness) == "17"; }, "sensor.brightness = 17");
  const auto& row = browser.rows.at(brightness);
  CHECK(numberOf(row.member("number")) == 17);
  CHECK(numberOf(row.member("seqno")) >= 2);
  CHECK(numberOf(row.member("owner")) == s.id);
  CHECK(stringOf(row.member("mimetype")) == "text/plain");

  // A narrower filter, by name, starts the table over with only what it matches.
  browser.socket.send(R"({"op":"filter","pattern":"lamp.**"})");
  browser.waitUntil([&] { return browser.filter == "lamp.**"; }, "the table for lamp.**");
  browser.waitUntil([&] { return browser.rows.count(std::to_string(l.id) + ".light") > 0; },
                    "lamp.light in the narrowed table");
  for (const auto& [id, r] : browser.rows) CHECK(numberOf(r.member("owner")) == l.id);
  CHECK(view.process->running());
}

TEST_CASE("an edit on the page reaches the owner, and the owner refusing one comes back",
          "[integration]") {
  const auto ecology = uniqueEcology("view-edit");
  auto lamp = startNode(ecology, {"--peis-name", "lamp", "--peis-set-tuple", "light=off"});
  // This owner takes at most 64 bytes a value: longer writes it refuses.
  auto small = startNode(ecology, {"--peis-name", "small", "--peis-max-data", "64"});
  const auto l = awaitNode(*lamp);
  const auto sm = awaitNode(*small);
  View view(ecology, {"--max-edit", "2000"});
  Page browser(view.port);
  browser.waitUntil([&] { return browser.peis().count(l.id) && browser.peis().count(sm.id); },
                    "both PEIS in the graph");
  browser.waitUntil([&] { return browser.value(std::to_string(l.id) + ".light") == "off"; },
                    "lamp.light in the table");

  // get: the whole value, to edit it.
  browser.socket.send(R"({"op":"get","request":1,"tuple":"lamp.light"})");
  const auto got = browser.reply(1);
  CHECK(*got.member("ok")->asBool());
  CHECK(stringOf(got.member("value")) == "off");

  browser.socket.send(setCommand(2, "lamp.light", "on"));
  const auto accepted = browser.reply(2);
  INFO(stringOf(accepted.member("error")));
  CHECK(*accepted.member("ok")->asBool());
  CHECK(stringOf(accepted.member("tuple")) == std::to_string(l.id) + ".light");
  CHECK(runCli(ecology, {"get", "lamp.light"}).out == "on\n");
  browser.waitUntil([&] { return browser.value(std::to_string(l.id) + ".light") == "on"; },
                    "the edit in the table");

  // A value over the owner's limit: the owner's error, naming it.
  browser.socket.send(setCommand(3, "small.note", std::string(100, 'x')));
  const auto refused = browser.reply(3);
  CHECK_FALSE(*refused.member("ok")->asBool());
  CHECK_THAT(stringOf(refused.member("error")), Contains("PEIS " + std::to_string(sm.id)));
  CHECK(stringOf(refused.member("code")) == "too large");

  // Writes to a PEIS that is not there, and to a name nobody carries.
  browser.socket.send(setCommand(4, "1.x", "1"));
  const auto unreachable = browser.reply(4);
  CHECK_FALSE(*unreachable.member("ok")->asBool());
  CHECK(stringOf(unreachable.member("code")) == "unreachable");
  browser.socket.send(setCommand(5, "nobody.x", "1"));
  CHECK_THAT(stringOf(browser.reply(5).member("error")), Contains("nobody"));

  // Over this view's own edit limit: refused before any write.
  browser.socket.send(setCommand(6, "lamp.light", std::string(2001, 'y')));
  const auto tooBig = browser.nextError();
  CHECK_THAT(stringOf(tooBig.member("error")),
             Contains("over this view's edit limit of 2000 bytes"));
  CHECK(numberOf(tooBig.member("request")) == 6);
  CHECK(runCli(ecology, {"get", "lamp.light"}).out == "on\n");
}

TEST_CASE("bad messages from a page get clear errors and never stop the view", "[fault]") {
  const auto ecology = uniqueEcology("view-bad");
  auto node = startNode(ecology, {"--peis-name", "node", "--peis-set-tuple", "x=1"});
  const auto n = awaitNode(*node);
  View view(ecology, {"--max-edit", "1000"});
  Page browser(view.port);
  browser.waitUntil([&] { return browser.peis().count(n.id) > 0; }, "the node in the graph");

  auto error = [&](const std::string& sent) {
    browser.socket.send(sent);
    return stringOf(browser.nextError().member("error"));
  };
  CHECK_THAT(error("this is not json"), Contains("the message is not JSON"));
  CHECK_THAT(error("[1,2]"), Contains("must be a JSON object"));
  CHECK_THAT(error(R"({"op":"explode"})"), Contains("unknown op 'explode'"));
  CHECK_THAT(error(R"({"op":"set","request":1})"), Contains("needs \"tuple\""));
  CHECK_THAT(error(R"({"op":"filter","pattern":"no dot"})"), Contains("is not a pattern"));
  CHECK_THAT(error(R"({"op":"filter","pattern":"*.a..b"})"), Contains("bad key pattern"));
  CHECK_THAT(error(R"({"op":"filter","pattern":"nobody.*"})"), Contains("nobody"));
  CHECK_THAT(error(R"({"op":"plot","tuple":"not a tuple"})"), Contains("not a tuple"));
  CHECK_THAT(error(std::string(40, '[') + std::string(40, ']')), Contains("nested deeper"));
  browser.socket.sendBinary(std::string("\x00\x01\x02", 3));
  CHECK_THAT(stringOf(browser.nextError().member("error")),
             Contains("binary messages are not understood"));

  // A message over the view's limit (max-edit x 6 + 64 KiB) closes that
  // connection with 1009; the view goes on serving others.
  // (The message is barely over the limit, so it is all sent before the
  // view answers: a longer one could meet the closed connection mid-write.)
  browser.socket.send(setCommand(9, "node.x", std::string(1000 * 6 + 64 * 1024, 'z')));
  while (browser.socket.next(kDeadline)) {
  }
  CHECK(browser.socket.closed());
  CHECK(browser.socket.closeCode() == 1009);

  Page again(view.port);
  again.waitUntil([&] { return again.hello.has_value(); }, "hello on a new connection");
  CHECK(view.process->running());

  // A page of another origin may not connect (cross-site WebSocket).
  CHECK_THROWS_WITH(ViewSocket(view.port, "http://evil.example"), Contains("declined"));
  const auto upgrade = httpGet(view.port, "/ws", "127.0.0.1",
                               {{"Upgrade", "websocket"},
                                {"Connection", "Upgrade"},
                                {"Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="},
                                {"Sec-WebSocket-Version", "13"},
                                {"Origin", "http://evil.example"}});
  CHECK(upgrade.status == 403);
  CHECK_THAT(upgrade.body, Contains("origin 'http://evil.example' refused"));
  CHECK(statOf(view.port, "refusedRequests") >= 2);
}

TEST_CASE("a page that stops reading is dropped and counted, the others go on", "[fault]") {
  const auto ecology = uniqueEcology("view-slow");
  auto node = startNode(ecology, {"--peis-name", "node", "--peis-set-tuple", "x=1"});
  const auto n = awaitNode(*node);
  peis::test::TempDir dir;
  // More than a page's socket buffers hold: its message has to wait for it.
  const std::string big = dir.write("big.txt", std::string(3 << 20, 'b'));
  REQUIRE(runCli(ecology, {"set", "node.big", "@" + big}).status == 0);
  View view(ecology, {"--max-queue", "8000000", "--stall-timeout", "2", "--max-edit", "4000000"});

  Page healthy(view.port);
  const std::string x = std::to_string(n.id) + ".x";
  healthy.waitUntil([&] { return healthy.value(x) == "1"; }, "x = 1");
  healthy.waitUntil([&] { return healthy.rows.count(std::to_string(n.id) + ".big") > 0; },
                    "node.big in the view");

  {
    // Asks for the 3 MB value and never reads: its message waits, stalled.
    ViewSocket stalled(view.port, "", 4096);
    stalled.send(R"({"op":"get","request":1,"tuple":"node.big"})");
    REQUIRE_WAIT([&] { return statOf(view.port, "clientsDroppedStalled") >= 1; }, kDeadline);
  }
  {
    // Floods requests without reading: its queue passes the bound at once.
    ViewSocket flooding(view.port, "", 4096);
    for (int i = 0; i < 5; ++i) flooding.send(R"({"op":"get","request":1,"tuple":"node.big"})");
    REQUIRE_WAIT([&] { return statOf(view.port, "clientsDroppedQueue") >= 1; }, kDeadline);
  }
  CHECK(statOf(view.port, "clientsDropped") == 2);
  CHECK(statOf(view.port, "clientsDroppedStalled") == 1);
  // The count is a tuple of the view too.
  const auto viewId = static_cast<long>(statOf(view.port, "self"));
  REQUIRE_WAIT(
      [&] {
        return runCli(ecology, {"get", std::to_string(viewId) + ".view.clients.dropped"}).out ==
               "2\n";
      },
      kDeadline);
  // The healthy page still gets changes.
  REQUIRE(runCli(ecology, {"set", "node.x", "2"}).status == 0);
  healthy.waitUntil([&] { return healthy.value(x) == "2"; }, "x = 2 after the drops");
}

TEST_CASE("a burst of writes reaches a page coalesced, ending at the last value", "[integration]") {
  const auto ecology = uniqueEcology("view-burst");
  peis::Kernel owner(peis::test::kernelOptions(ecology, "burst"));
  owner.set("counter", "0");
  View view(ecology, {"--rate", "2"});
  Page browser(view.port);
  const std::string counter = std::to_string(owner.id()) + ".counter";
  browser.waitUntil([&] { return browser.value(counter) == "0"; }, "counter = 0");
  int rowsSeen = 0;
  browser.onUpdate = [&](const json::Value& m) {
    int rowsOfCounter = 0;
    if (const auto* table = m.member("table"))
      for (const auto& row : arrayOf(table->member("rows")))
        rowsOfCounter += stringOf(row.member("id")) == counter;
    CHECK(rowsOfCounter <= 1);  // a tuple is in an update at most once
    rowsSeen += rowsOfCounter;
  };
  constexpr int kWrites = 2000;
  for (int i = 1; i <= kWrites; ++i) owner.set("counter", std::to_string(i));
  browser.waitUntil([&] { return browser.value(counter) == std::to_string(kWrites); },
                    "the counter's last value");
  // Two updates a second at most: 2000 rows would take 1000 s of writing;
  // the loop above takes a tiny part of that, so the page saw far fewer.
  CHECK(rowsSeen >= 1);
  CHECK(rowsSeen < kWrites);
}

TEST_CASE("image tuples are served as pictures, raw camera images as PNG", "[integration]") {
  const auto ecology = uniqueEcology("view-image");
  auto node = startNode(ecology, {"--peis-name", "camera", "--peis-set-tuple", "note=hello"});
  const auto n = awaitNode(*node);
  peis::test::TempDir dir;
  cv::Mat image(48, 64, CV_8UC3, cv::Scalar(20, 120, 220));
  const auto raw = peis::camera::encodeImage(image, peis::camera::ImageFormat::Raw);
  const std::string file = dir.write("frame.raw", raw.data);
  REQUIRE(runCli(ecology, {"set", "camera.image", "@" + file, "--mimetype", raw.mimetype}).status ==
          0);
  View view(ecology);
  Page browser(view.port);
  const std::string id = std::to_string(n.id) + ".image";
  browser.waitUntil([&] { return browser.rows.count(id) > 0; }, "the image's row");
  const auto& row = browser.rows.at(id);
  CHECK(row.member("value")->isNull());
  CHECK(*row.member("binary")->asBool());
  CHECK(stringOf(row.member("mimetype")) == raw.mimetype);
  CHECK(numberOf(row.member("size")) == 64 * 48 * 3);

  const auto picture = httpGet(view.port, "/image?tuple=" + id);
  REQUIRE(picture.status == 200);
  CHECK(picture.contentType == "image/png");
  CHECK(picture.body.substr(0, 4) == "\x89PNG");
  CHECK(httpGet(view.port, "/image?tuple=camera.image").status == 200);
  browser.waitUntil([&] { return browser.rows.count(std::to_string(n.id) + ".note") > 0; },
                    "the note's row");
  const auto notPicture = httpGet(view.port, "/image?tuple=camera.note");
  CHECK(notPicture.status == 415);
  CHECK_THAT(notPicture.body, Contains("not a picture this view shows"));
  CHECK(httpGet(view.port, "/image?tuple=camera.nothing").status == 404);
  CHECK(httpGet(view.port, "/image").status == 400);
  CHECK(httpGet(view.port, "/image?tuple=%zz").status == 400);
  // A binary value is not edited as text.
  browser.socket.send(R"({"op":"get","request":1,"tuple":"camera.image"})");
  const auto reply = browser.reply(1);
  CHECK_FALSE(*reply.member("ok")->asBool());
  CHECK(stringOf(reply.member("code")) == "binary");
}

TEST_CASE("peis view runs peis-view and prints the URL, bad options exit 2", "[integration]") {
  const auto ecology = uniqueEcology("view-cli");
  const std::string dir = viewPath().substr(0, viewPath().rfind('/'));
  const Process::Environment env{{"PEIS_EXEC_PATH", dir}};
  {
    Process help({peis::test::peisCliPath(), "view", "--help"}, env);
    REQUIRE(help.wait(kDeadline) == 0);
    CHECK_THAT(help.out(), Contains("Usage: peis view") && Contains("--rate N"));
  }
  {
    Process view(peis::test::cliArgs(ecology, {"view", "--port", "0"}), env);
    REQUIRE_WAIT(
        [&] { return view.out().find("peis view: http://127.0.0.1:") != std::string::npos; },
        kDeadline);
    view.kill(SIGTERM);
    CHECK(view.wait(kDeadline) == 0);
  }
  auto exitOf = [&](std::vector<std::string> args) {
    args.insert(args.begin(), viewPath());
    Process p(args, {{"PEIS_DISCOVERY_SCOPE", "off"}});
    const auto status = p.wait(kDeadline);
    INFO(p.describe());
    REQUIRE(status.has_value());
    return std::make_pair(*status, p.err());
  };
  CHECK(exitOf({"--rate", "0"}) ==
        std::make_pair(
            2, std::string("peis view: --rate: updates per second, 0.1..100 (see --help)\n")));
  CHECK(exitOf({"--bogus"}).first == 2);
  CHECK_THAT(exitOf({"--filter", "no-dot", "--port", "0"}).second,
             Contains("--filter: 'no-dot' is not a pattern"));
  CHECK_THAT(exitOf({"--meta", "*.a..b", "--port", "0"}).second,
             Contains("--meta: bad key pattern"));
  // A port that is taken: a clear error.
  View first(ecology);
  const auto taken = exitOf({"--port", std::to_string(first.port)});
  CHECK(taken.first == 2);
  CHECK_THAT(taken.second, Contains("cannot listen on 127.0.0.1:" + std::to_string(first.port)) &&
                               Contains("--port N picks another port"));
}

TEST_CASE("the meta-level panel shows a real configurator's goal, answer, deployment and events",
          "[integration]") {
  const auto ecology = uniqueEcology("view-meta");
  const std::string descriptors = std::string(PEIS_SOURCE_DIR) + "/tests/meta/descriptors/";
  std::vector<std::unique_ptr<Process>> meta;
  auto start = [&](std::vector<std::string> argv) {
    argv.insert(argv.end(), {"--peis-ecology", ecology});
    meta.push_back(std::make_unique<Process>(argv));
  };
  for (const auto& [name, descriptor] :
       {std::pair{"pa", "position-cheap.yaml"}, std::pair{"c1", "consumer.yaml"}})
    start({PEIS_SYNTHETIC_PATH, "--peis-name", name, "--descriptor", descriptors + descriptor,
           "--period-ms", "100", "--freshness-ms", "1000"});
  start({PEIS_CONFIGURATOR_PATH, "--peis-name", "cfg"});
  auto everything = [&] {
    std::string text;
    for (const auto& p : meta) text += p->describe() + "\n";
    return text;
  };
  INFO(everything());
  REQUIRE(waitFor(
      [&] {
        return runCli(ecology, {"get", "cfg.config.configurator", "--wait", "5"}).out == "active\n";
      },
      60s));
  View view(ecology);
  Page browser(view.port);
  browser.waitUntil([&] { return browser.idOf("cfg") && browser.idOf("c1") && browser.idOf("pa"); },
                    "cfg, c1 and pa in the graph");
  const long cfg = browser.idOf("cfg"), c1 = browser.idOf("c1"), pa = browser.idOf("pa");
  browser.waitUntil([&] { return browser.metaValue(cfg, "config.configurator") == "active"; },
                    "cfg.config.configurator = active in the meta-level panel");

  // A goal posted as a tuple; the configurator plans, deploys and answers.
  REQUIRE(runCli(ecology, {"set", "cfg.config.goal.view", "position@c1.mi-position"}).status == 0);
  browser.waitUntil(
      [&] { return browser.metaValue(cfg, "config.goal.view") == "position@c1.mi-position"; },
      "the goal tuple in the panel");
  browser.waitUntil(
      [&] {
        return browser.metaValue(cfg, "config.goal-status").find("config.goal.view") !=
                   std::string::npos &&
               browser.metaValue(cfg, "config.goal-status").find("deployed") != std::string::npos;
      },
      "the configurator's answer 'deployed' in the panel");
  browser.waitUntil(
      [&] {
        return browser.metaValue(cfg, "config.deployed").find("c1.mi-position <- pa.position") !=
               std::string::npos;
      },
      "config.deployed in the panel");
  browser.waitUntil(
      [&] {
        return browser.metaValue(c1, "config.owned").find("mi-position") != std::string::npos;
      },
      "the deployment's record on the consumer");
  auto deployedEvent = [&] {
    for (const auto& entry : browser.log) {
      const auto* row = entry.member("row");
      if (numberOf(row->member("owner")) == cfg &&
          stringOf(row->member("key")).rfind("config.event.", 0) == 0 &&
          stringOf(row->member("value")).rfind("deployed generation", 0) == 0)
        return true;
    }
    return false;
  };
  browser.waitUntil(deployedEvent, "the configurator's 'deployed' event in the log");
  auto deployedLink = [&] {
    if (!browser.graph) return false;
    for (const auto& c : arrayOf(browser.graph->member("configuration")))
      if (numberOf(c.member("consumer")) == c1 && numberOf(c.member("producer")) == pa &&
          stringOf(c.member("producerKey")) == "position")
        return true;
    return false;
  };
  browser.waitUntil(deployedLink, "c1.mi-position <- pa.position in the graph");
  CHECK(view.process->running());
}
