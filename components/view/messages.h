// The view's WebSocket protocol (docs/operating.md, "The view's protocol"):
// the commands a page sends, decoded and checked, and the messages the view
// sends, encoded. Every message is one JSON object in one text frame. Pure.
//
// Page -> view, each with "op":
//   {"op":"filter","pattern":"*.**"}                 the table's filter
//   {"op":"plot","tuple":"12.temperature"}           the plotted tuple (null: none)
//   {"op":"get","request":N,"tuple":"12.x"}          a tuple's whole value (to edit it)
//   {"op":"set","request":N,"tuple":"12.x","value":"on"[,"mimetype":"text/plain"]}
//                                                    a write to the tuple's owner
// View -> page, each with "type":
//   hello     once: the view's PEIS, ecology, limits, the meta-level filters
//   update    at most once per tick: table rows (changed since the last
//             update, coalesced per tuple), rates, the meta-level's rows and
//             log, the plot's new samples, the graph when it changed
//   reply     the answer to get or set: ok with the value or the owner's
//             seqno, or the error (for set: the owner's, "PEIS 12: ...")
//   error     a message the view could not take: what was wrong
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "view/graph.h"
#include "view/tuple_store.h"

namespace peis::view {

struct FilterCommand {
  std::string pattern;
};
struct PlotCommand {
  std::optional<std::string> tuple;  // OWNER.KEY as written
};
struct GetCommand {
  std::uint64_t request = 0;
  std::string tuple;
};
struct SetCommand {
  std::uint64_t request = 0;
  std::string tuple;
  std::string value;
  std::optional<std::string> mimetype;
};
using Command = std::variant<FilterCommand, PlotCommand, GetCommand, SetCommand>;

struct CommandError {
  std::string message;
  std::string op;                        // when the message named one
  std::optional<std::uint64_t> request;  // when the message carried one
};

// Decodes one message of a page. Values longer than `maxValueBytes` and
// everything malformed give a CommandError that says what is wrong.
std::variant<Command, CommandError> decodeCommand(std::string_view text, std::size_t maxValueBytes);

struct HelloInfo {
  PeisId self = 0;
  std::string name;
  std::string ecology;
  double updateRate = 0;
  double imageRate = 0;
  std::size_t maxEditBytes = 0;
  std::size_t maxMessageBytes = 0;
  std::string filter;
  std::vector<std::string> metaFilters;
};
std::string encodeHello(const HelloInfo& hello);

// One table (or meta-level) part of an update.
struct RowsPart {
  bool reset = false;
  bool more = false;
  std::string filter;  // the table's filter text (empty for the meta part)
  std::vector<StoredTuple> rows;
  std::vector<double> rates;  // one per row
  std::vector<std::string> deleted;
};

struct Update {
  Timestamp now{};
  std::optional<RowsPart> table;
  std::vector<std::pair<std::string, double>> rates;  // id, rate: refreshed rates
  std::optional<RowsPart> meta;
  std::vector<TupleStore::LogEntry> log;
  bool logReset = false;
  struct Plot {
    std::string tuple;
    bool reset = false;
    std::vector<Sample> samples;
  };
  std::optional<Plot> plot;
  std::optional<std::string> graphJson;  // encodeGraph's text
  bool empty() const {
    return !table && rates.empty() && !meta && log.empty() && !logReset && !plot && !graphJson;
  }
};
std::string encodeUpdate(const Update& update);

std::string encodeGraph(const Graph& graph, PeisId self);

std::string encodeGetReply(std::uint64_t request, const std::string& tuple,
                           const std::string& value, const std::string& mimetype,
                           std::uint64_t seqno);
std::string encodeSetReply(std::uint64_t request, const std::string& tuple, std::uint64_t seqno);
std::string encodeReplyError(std::uint64_t request, const std::string& op, const std::string& tuple,
                             const std::string& error, const std::string& code);
std::string encodeError(const CommandError& error);

// Microseconds since the Unix epoch (0 for kNoTime).
std::int64_t micros(Timestamp t);

}  // namespace peis::view
