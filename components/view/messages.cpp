// Encoding and decoding the view's WebSocket messages (messages.h).
#include "view/messages.h"

#include <cmath>

#include "view/json.h"

namespace peis::view {
namespace {

// Largest integer a JavaScript number holds exactly.
constexpr double kMaxSafeInteger = 9007199254740991.0;

const json::Value* field(const json::Value& message, const char* name) {
  const json::Value* value = message.member(name);
  return value && !value->isNull() ? value : nullptr;
}

std::string needString(const json::Value& message, const char* name, const std::string& op) {
  const json::Value* value = field(message, name);
  if (!value) throw CommandError{"'" + op + "' needs \"" + name + "\"", op, std::nullopt};
  if (const auto* text = value->asString()) return *text;
  throw CommandError{"\"" + std::string(name) + "\" must be a string, not " + value->typeName(), op,
                     std::nullopt};
}

std::uint64_t needRequest(const json::Value& message, const std::string& op) {
  const json::Value* value = field(message, "request");
  if (!value) throw CommandError{"'" + op + "' needs \"request\" (a number)", op, std::nullopt};
  const double* number = value->asNumber();
  if (!number || *number < 0 || *number > kMaxSafeInteger || std::floor(*number) != *number) {
    throw CommandError{"\"request\" must be a whole number from 0 to 2^53-1", op, std::nullopt};
  }
  return static_cast<std::uint64_t>(*number);
}

void writeRow(json::Writer& w, const StoredTuple& t, double rate) {
  w.beginObject();
  w.key("id").string(t.id());
  w.key("owner").integer(t.owner);
  w.key("key").string(t.key);
  w.key("creator").integer(t.creator);
  w.key("mimetype").string(t.mimetype);
  w.key("binary").boolean(t.binary);
  w.key("size").unsignedInteger(t.size);
  if (t.binary)
    w.key("value").null();
  else
    w.key("value").string(t.preview);
  w.key("truncated").boolean(t.truncated);
  if (t.number) w.key("number").number(*t.number);
  w.key("seqno").unsignedInteger(t.seqno);
  w.key("tsWrite").integer(micros(t.tsWrite));
  w.key("tsUser").integer(micros(t.tsUser));
  w.key("tsExpire").integer(micros(t.tsExpire));
  w.key("arrival").integer(micros(t.arrival));
  w.key("rate").number(rate);
  w.endObject();
}

void writeRows(json::Writer& w, const RowsPart& part) {
  w.beginObject();
  w.key("reset").boolean(part.reset);
  w.key("more").boolean(part.more);
  if (!part.filter.empty()) w.key("filter").string(part.filter);
  w.key("rows").beginArray();
  for (std::size_t i = 0; i < part.rows.size(); ++i) {
    writeRow(w, part.rows[i], i < part.rates.size() ? part.rates[i] : 0.0);
  }
  w.endArray();
  w.key("deleted").beginArray();
  for (const auto& id : part.deleted) w.string(id);
  w.endArray();
  w.endObject();
}

}  // namespace

std::int64_t micros(Timestamp t) { return t.time_since_epoch().count(); }

std::variant<Command, CommandError> decodeCommand(std::string_view text,
                                                  std::size_t maxValueBytes) {
  json::Value message;
  try {
    message = json::parse(text);
  } catch (const json::ParseError& e) {
    return CommandError{std::string("the message is not JSON: ") + e.what(), "", std::nullopt};
  }
  if (!message.asObject()) {
    return CommandError{std::string("a message must be a JSON object, not ") + message.typeName(),
                        "", std::nullopt};
  }
  std::optional<std::uint64_t> request;
  if (const auto* r = field(message, "request"); r && r->asNumber() && *r->asNumber() >= 0 &&
                                                 *r->asNumber() <= kMaxSafeInteger &&
                                                 std::floor(*r->asNumber()) == *r->asNumber())
    request = static_cast<std::uint64_t>(*r->asNumber());
  const json::Value* opValue = field(message, "op");
  if (!opValue || !opValue->asString()) {
    return CommandError{"a message needs \"op\": filter, plot, get or set", "", request};
  }
  const std::string op = *opValue->asString();
  try {
    if (op == "filter") return Command{FilterCommand{needString(message, "pattern", op)}};
    if (op == "plot") {
      PlotCommand plot;
      if (field(message, "tuple")) plot.tuple = needString(message, "tuple", op);
      return Command{plot};
    }
    if (op == "get") {
      GetCommand get;
      get.request = needRequest(message, op);
      get.tuple = needString(message, "tuple", op);
      return Command{get};
    }
    if (op == "set") {
      SetCommand set;
      set.request = needRequest(message, op);
      set.tuple = needString(message, "tuple", op);
      set.value = needString(message, "value", op);
      if (set.value.size() > maxValueBytes) {
        throw CommandError{"a value of " + std::to_string(set.value.size()) +
                               " bytes is over this view's edit limit of " +
                               std::to_string(maxValueBytes) + " bytes (peis view --max-edit)",
                           op, std::nullopt};
      }
      if (field(message, "mimetype")) set.mimetype = needString(message, "mimetype", op);
      return Command{set};
    }
  } catch (CommandError& e) {
    e.request = request;
    return e;
  }
  std::string shown = op.size() > 40 ? op.substr(0, 40) + "..." : op;
  return CommandError{"unknown op '" + shown + "' (known: filter, plot, get, set)", "", request};
}

std::string encodeHello(const HelloInfo& hello) {
  json::Writer w;
  w.beginObject();
  w.key("type").string("hello");
  w.key("self").integer(hello.self);
  w.key("name").string(hello.name);
  w.key("ecology").string(hello.ecology);
  w.key("updateRate").number(hello.updateRate);
  w.key("imageRate").number(hello.imageRate);
  w.key("maxEditBytes").unsignedInteger(hello.maxEditBytes);
  w.key("maxMessageBytes").unsignedInteger(hello.maxMessageBytes);
  w.key("filter").string(hello.filter);
  w.key("metaFilters").beginArray();
  for (const auto& f : hello.metaFilters) w.string(f);
  w.endArray();
  w.endObject();
  return w.take();
}

std::string encodeUpdate(const Update& update) {
  json::Writer w;
  w.beginObject();
  w.key("type").string("update");
  w.key("now").integer(micros(update.now));
  if (update.table) {
    w.key("table");
    writeRows(w, *update.table);
  }
  if (!update.rates.empty()) {
    w.key("rates").beginObject();
    for (const auto& [id, rate] : update.rates) w.key(id).number(rate);
    w.endObject();
  }
  if (update.meta) {
    w.key("meta");
    writeRows(w, *update.meta);
  }
  if (!update.log.empty() || update.logReset) {
    w.key("log").beginObject();
    w.key("reset").boolean(update.logReset);
    w.key("entries").beginArray();
    for (const auto& entry : update.log) {
      w.beginObject();
      w.key("seq").unsignedInteger(entry.seq);
      w.key("deleted").boolean(entry.tuple.deleted);
      w.key("row");
      writeRow(w, entry.tuple, 0.0);
      w.endObject();
    }
    w.endArray();
    w.endObject();
  }
  if (update.plot) {
    w.key("plot").beginObject();
    w.key("tuple").string(update.plot->tuple);
    w.key("reset").boolean(update.plot->reset);
    w.key("samples").beginArray();
    for (const auto& s : update.plot->samples) {
      w.beginArray().integer(micros(s.time)).number(s.value).endArray();
    }
    w.endArray();
    w.endObject();
  }
  if (update.graphJson) w.key("graph").raw(*update.graphJson);
  w.endObject();
  return w.take();
}

std::string encodeGraph(const Graph& graph, PeisId self) {
  json::Writer w;
  w.beginObject();
  w.key("self").integer(self);
  w.key("nodes").beginArray();
  for (const auto& n : graph.nodes) {
    w.beginObject();
    w.key("id").integer(n.id);
    w.key("name").string(n.name);
    w.key("hops").integer(n.hops);
    w.key("tool").boolean(n.tool);
    w.key("self").boolean(n.self);
    w.key("host").string(n.host);
    w.key("component").string(n.component);
    w.key("status").string(n.status);
    w.key("causes").string(n.causes);
    w.endObject();
  }
  w.endArray();
  w.key("links").beginArray();
  for (const auto& [a, b] : graph.links) w.beginArray().integer(a).integer(b).endArray();
  w.endArray();
  w.key("configuration").beginArray();
  for (const auto& c : graph.configuration) {
    w.beginObject();
    w.key("consumer").integer(c.consumer);
    w.key("key").string(c.metaKey);
    w.key("value").string(c.value);
    if (c.producer)
      w.key("producer").integer(*c.producer);
    else
      w.key("producer").null();
    w.key("producerKey").string(c.producerKey);
    w.key("producerReachable").boolean(c.producerReachable);
    w.endObject();
  }
  w.endArray();
  w.endObject();
  return w.take();
}

namespace {

// A reply's opening fields; the caller adds its own and ends the object.
json::Writer replyHead(const std::string& op, std::uint64_t request, bool ok,
                       const std::string& tuple) {
  json::Writer w;
  w.beginObject();
  w.key("type").string("reply");
  w.key("op").string(op);
  w.key("request").unsignedInteger(request);
  w.key("ok").boolean(ok);
  w.key("tuple").string(tuple);
  return w;
}

}  // namespace

std::string encodeGetReply(std::uint64_t request, const std::string& tuple,
                           const std::string& value, const std::string& mimetype,
                           std::uint64_t seqno) {
  json::Writer w = replyHead("get", request, true, tuple);
  w.key("value").string(value);
  w.key("mimetype").string(mimetype);
  w.key("seqno").unsignedInteger(seqno);
  return w.endObject().take();
}

std::string encodeSetReply(std::uint64_t request, const std::string& tuple, std::uint64_t seqno) {
  json::Writer w = replyHead("set", request, true, tuple);
  w.key("seqno").unsignedInteger(seqno);
  return w.endObject().take();
}

std::string encodeReplyError(std::uint64_t request, const std::string& op, const std::string& tuple,
                             const std::string& error, const std::string& code) {
  json::Writer w = replyHead(op, request, false, tuple);
  w.key("error").string(error);
  w.key("code").string(code);
  return w.endObject().take();
}

std::string encodeError(const CommandError& error) {
  json::Writer w;
  w.beginObject();
  w.key("type").string("error");
  w.key("error").string(error.message);
  if (!error.op.empty()) w.key("op").string(error.op);
  if (error.request) w.key("request").unsignedInteger(*error.request);
  w.endObject();
  return w.take();
}

}  // namespace peis::view
