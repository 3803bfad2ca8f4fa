// What one page has been sent, and what it is sent next: the table's filter
// and cursor into the store, the meta-level's cursor and log position, the
// plotted tuple and how many of its samples went, the graph version, and
// the rates shown. `collect` (under the store's lock, copying) gathers one
// update; the caller encodes it afterwards without the lock. Called once
// per tick and only when the page's previous messages are all written, so a
// page gets at most one update per tick, each tuple at most once in it, with
// its latest value: per tuple at most `--rate` updates per second. Pure.
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "view/filter.h"
#include "view/messages.h"
#include "view/tuple_store.h"

namespace peis::view {

struct ClientLimits {
  std::size_t maxRows = 500;  // rows per part of one update; the rest follows next tick
  std::size_t maxLog = 200;   // meta-level log entries per update
  std::chrono::milliseconds rateRefresh{1000};  // rates of unchanged rows
};

class ClientState {
 public:
  explicit ClientState(Filter filter, ClientLimits limits = {});

  // A new table filter: the table starts over.
  void setFilter(Filter filter);
  const Filter& filter() const { return table_.front(); }
  // The plotted tuple (none: no plot); its samples start over.
  void setPlot(std::optional<TupleRef> tuple);
  const std::optional<TupleRef>& plot() const { return plot_; }

  // The next update, or an empty one when nothing is new. `graphJson` is
  // the current graph (encodeGraph) and `graphVersion` its version.
  Update collect(const TupleStore& store, std::uint64_t graphVersion,
                 const std::shared_ptr<const std::string>& graphJson, Timestamp now);

 private:
  RowsPart rowsSince(const TupleStore& store, const std::vector<Filter>& filters,
                     std::uint64_t& cursor, Timestamp now, bool trackRates);

  ClientLimits limits_;
  std::vector<Filter> table_;  // exactly one
  std::uint64_t tableCursor_ = 0;
  std::uint64_t metaCursor_ = 0;
  std::uint64_t logSeen_ = 0;
  bool logStarted_ = false;
  std::optional<TupleRef> plot_;
  std::uint64_t plotSeen_ = 0;
  bool plotPending_ = false;  // a new plot not yet sent
  std::uint64_t graphSent_ = 0;
  std::map<TupleRef, double> shownRates_;  // table rows with the rate last sent
  Timestamp lastRateRefresh_{};
};

}  // namespace peis::view
