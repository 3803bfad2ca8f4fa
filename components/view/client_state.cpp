// One page's cursors and what it is sent next (client_state.h).
#include "view/client_state.h"

#include <cmath>

namespace peis::view {

ClientState::ClientState(Filter filter, ClientLimits limits) : limits_(limits) {
  table_.push_back(std::move(filter));
}

void ClientState::setFilter(Filter filter) {
  table_.front() = std::move(filter);
  tableCursor_ = 0;
  shownRates_.clear();
}

void ClientState::setPlot(std::optional<TupleRef> tuple) {
  plot_ = std::move(tuple);
  plotSeen_ = 0;
  plotPending_ = true;
}

RowsPart ClientState::rowsSince(const TupleStore& store, const std::vector<Filter>& filters,
                                std::uint64_t& cursor, Timestamp now, bool trackRates) {
  RowsPart part;
  auto changes = store.changesSince(cursor, filters, limits_.maxRows);
  part.reset = changes.reset;
  part.more = changes.more;
  cursor = changes.cursor;
  if (trackRates && changes.reset) shownRates_.clear();
  for (auto& row : changes.rows) {
    const TupleRef ref{row.owner, row.key};
    if (row.deleted) {
      part.deleted.push_back(row.id());
      if (trackRates) shownRates_.erase(ref);
      continue;
    }
    const double rate = store.rate(row.owner, row.key, now);
    if (trackRates) shownRates_[ref] = rate;
    part.rates.push_back(rate);
    part.rows.push_back(std::move(row));
  }
  return part;
}

Update ClientState::collect(const TupleStore& store, std::uint64_t graphVersion,
                            const std::shared_ptr<const std::string>& graphJson, Timestamp now) {
  Update update;
  update.now = now;
  const bool tableStarts = tableCursor_ == 0;
  if (tableStarts || store.version() > tableCursor_) {
    RowsPart part = rowsSince(store, table_, tableCursor_, now, true);
    part.filter = filter().text;
    if (part.reset || !part.rows.empty() || !part.deleted.empty()) update.table = std::move(part);
  }
  // Rates of rows that did not change: they fall while a tuple is quiet.
  if (now - lastRateRefresh_ >= limits_.rateRefresh) {
    lastRateRefresh_ = now;
    for (auto& [ref, shown] : shownRates_) {
      const double rate = store.rate(ref.owner, ref.key, now);
      const bool changed =
          std::abs(rate - shown) > 0.05 * std::max(rate, shown) || (rate == 0.0) != (shown == 0.0);
      if (!changed) continue;
      shown = rate;
      update.rates.emplace_back(ref.str(), rate);
    }
  }
  const auto& metaFilters = store.logFilters();
  if (!metaFilters.empty()) {
    if (metaCursor_ == 0 || store.version() > metaCursor_) {
      const bool starts = metaCursor_ == 0;
      RowsPart part = rowsSince(store, metaFilters, metaCursor_, now, false);
      if (starts || part.reset || !part.rows.empty() || !part.deleted.empty())
        update.meta = std::move(part);
    }
    auto log = store.logSince(logSeen_, limits_.maxLog);
    update.logReset = !logStarted_ || log.reset;
    logStarted_ = true;
    logSeen_ = log.last;
    update.log = std::move(log.entries);
  }
  if (plot_) {
    auto chunk = store.historySince(plot_->owner, plot_->key, plotSeen_);
    if (plotPending_ || chunk.reset || !chunk.samples.empty()) {
      update.plot =
          Update::Plot{plot_->str(), plotPending_ || chunk.reset, std::move(chunk.samples)};
    }
    plotSeen_ = chunk.seen;
    plotPending_ = false;
  } else if (plotPending_) {
    update.plot = Update::Plot{"", true, {}};
    plotPending_ = false;
  }
  if (graphJson && graphVersion != graphSent_) {
    update.graphJson = *graphJson;
    graphSent_ = graphVersion;
  }
  return update;
}

}  // namespace peis::view
